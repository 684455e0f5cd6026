"""Reads the blueprint store of a .rrd with rerun-sdk 0.36.3 (`rr.experimental.RrdReader`) and
prints JSON: {"recordings": [{"application_id", "recording_id"}], "blueprints": [...],
"entities": {entity_path: {component: value}}} where each value is the first row's (blueprint
rows are logged once, on the `blueprint` timeline)."""
import json
import sys

import rerun as rr

reader = rr.experimental.RrdReader(sys.argv[1])
stores = lambda entries: [{"application_id": s.application_id, "recording_id": s.recording_id} for s in entries]
out = {"recordings": stores(reader.recordings()), "blueprints": stores(reader.blueprints()), "entities": {}}
for bp in reader.blueprints()[:1]:
    for chunk in reader.stream(store=bp):
        batch = chunk.to_record_batch()
        entity = out["entities"].setdefault(str(chunk.entity_path), {})
        for name in batch.schema.names:
            if ":" in name:
                value = batch.column(name).to_pylist()[0]
                entity[name] = value
json.dump(out, sys.stdout)
