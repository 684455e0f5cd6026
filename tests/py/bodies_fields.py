"""The message paths of the first `/bodies` message of a tumble MCAP, decoded with the Python
`mcap` reader and `mcap-protobuf-support`, in Foxglove's path syntax (`total_energy`,
`bodies[0].angular_momentum.x`, ...): {"paths": [...]}."""
import json
import sys

from google.protobuf.message import Message
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def walk(message, prefix, out):
    for field in message.DESCRIPTOR.fields:
        name = f"{prefix}{field.name}"
        value = getattr(message, field.name)
        if field.is_repeated if hasattr(field, "is_repeated") else field.label == field.LABEL_REPEATED:
            for i, item in enumerate(value):
                if isinstance(item, Message):
                    walk(item, f"{name}[{i}].", out)
                else:
                    out.append(f"{name}[{i}]")
        elif isinstance(value, Message):
            walk(value, f"{name}.", out)
        else:
            out.append(name)


with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    for _, channel, _, decoded in reader.iter_decoded_messages(topics=["/bodies"]):
        paths = []
        walk(decoded, "", paths)
        json.dump({"paths": paths}, sys.stdout)
        break
