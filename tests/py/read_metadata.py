"""Prints every metadata record of an MCAP file, read with the Python `mcap` reader, as JSON:
{name: {key: value}} (the last record of a name wins)."""
import json
import sys

from mcap.reader import make_reader

with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    out = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
print(json.dumps(out))
