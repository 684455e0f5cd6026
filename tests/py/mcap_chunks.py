"""Every chunk of each MCAP file named on the command line, as the Python `mcap` reader's summary
lists it: per chunk index, how many message indexes it lists and its time span; plus the profile,
the channels (topic, message encoding, schema name and encoding) and the message count per topic.
Used to check the rule Foxglove's reader enforces: no chunk without message indexes.

Prints {"files": {path: {"profile", "chunks": [{"message_indexes", "start", "end"}],
"channels": [{"topic", "message_encoding", "schema", "schema_encoding", "metadata"}],
"counts": {topic: n}, "metadata": [name, ...]}}}.
"""
import json
import sys

from mcap.reader import make_reader

out = {}
for path in sys.argv[1:]:
    with open(path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
        chunks = [
            {
                "message_indexes": len(ci.message_index_offsets),
                "start": ci.message_start_time,
                "end": ci.message_end_time,
            }
            for ci in summary.chunk_indexes
        ]
        channels = []
        for cid, ch in sorted(summary.channels.items()):
            schema = summary.schemas.get(ch.schema_id)
            channels.append(
                {
                    "topic": ch.topic,
                    "message_encoding": ch.message_encoding,
                    "schema": schema.name if schema else None,
                    "schema_encoding": schema.encoding if schema else None,
                    "metadata": dict(ch.metadata),
                }
            )
        counts = {}
        for cid, n in summary.statistics.channel_message_counts.items():
            counts[summary.channels[cid].topic] = n
        metadata = [m.name for m in reader.iter_metadata()]
        out[path] = {
            "profile": header.profile,
            "chunks": chunks,
            "channels": channels,
            "counts": counts,
            "metadata": metadata,
        }
json.dump({"files": out}, sys.stdout)
