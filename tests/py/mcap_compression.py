"""Per MCAP file named on the command line, as the Python `mcap` reader sees it: the set of chunk
compressions its chunk indexes name, the message count, and a SHA-256 over every decoded message
(channel topic, log time, data) in file order, so files that differ only in compression compare
equal. Prints {path: {"compressions": [...], "messages": n, "digest": hex}}.
"""
import hashlib
import json
import sys

from mcap.reader import make_reader

out = {}
for path in sys.argv[1:]:
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        compressions = sorted({ci.compression for ci in summary.chunk_indexes})
        digest = hashlib.sha256()
        n = 0
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            digest.update(channel.topic.encode())
            digest.update(message.log_time.to_bytes(8, "little"))
            digest.update(len(message.data).to_bytes(8, "little"))
            digest.update(message.data)
            n += 1
        out[path] = {"compressions": compressions, "messages": n, "digest": digest.hexdigest()}
print(json.dumps(out))
