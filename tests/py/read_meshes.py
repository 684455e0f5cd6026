"""Every `Mesh3D` of a .rrd (rerun-sdk 0.36.3, `rr.experimental.RrdReader`), as JSON:
{entity_path: {"positions": [[x, y, z], ...], "indices": [[a, b, c], ...], "normals": n}}."""
import json
import sys

import rerun as rr

out = {}
for chunk in rr.experimental.RrdReader(sys.argv[1]).stream():
    batch = chunk.to_record_batch()
    if "Mesh3D:vertex_positions" not in batch.schema.names:
        continue
    positions = batch.column("Mesh3D:vertex_positions").to_pylist()[0]
    indices = batch.column("Mesh3D:triangle_indices").to_pylist()[0]
    normals = batch.column("Mesh3D:vertex_normals").to_pylist()[0] if "Mesh3D:vertex_normals" in batch.schema.names else []
    out[str(chunk.entity_path)] = {"positions": positions, "indices": indices, "normals": len(normals or [])}
json.dump(out, sys.stdout)
