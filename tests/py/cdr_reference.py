"""Serializes messages with rosbags' own CDR serializer and ROS 2 Humble typestore (code nobody
on the tumble team wrote), as a byte reference for tumble's encoders.

Usage: cdr_reference.py SPEC.json, SPEC = {"joint_states": [{"sec", "nanosec", "frame_id",
"name": [..], "position": [..], "velocity": [..], "effort": [..]}], "tf": [{"sec", "nanosec",
"parent", "transforms": [[child, tx, ty, tz, qx, qy, qz, qw]]}]}.
Prints {"joint_states": [hex, ...], "tf": [hex, ...]}.
"""
import json
import sys

import numpy as np
from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_HUMBLE)
T = ts.types["builtin_interfaces/msg/Time"]
H = ts.types["std_msgs/msg/Header"]
JS = ts.types["sensor_msgs/msg/JointState"]
TF = ts.types["tf2_msgs/msg/TFMessage"]
TS = ts.types["geometry_msgs/msg/TransformStamped"]
TR = ts.types["geometry_msgs/msg/Transform"]
V3 = ts.types["geometry_msgs/msg/Vector3"]
Q = ts.types["geometry_msgs/msg/Quaternion"]

spec = json.load(open(sys.argv[1]))
out = {"joint_states": [], "tf": []}
for m in spec["joint_states"]:
    msg = JS(header=H(stamp=T(sec=m["sec"], nanosec=m["nanosec"]), frame_id=m["frame_id"]),
             name=m["name"],
             position=np.array(m["position"], dtype=np.float64),
             velocity=np.array(m["velocity"], dtype=np.float64),
             effort=np.array(m["effort"], dtype=np.float64))
    out["joint_states"].append(bytes(ts.serialize_cdr(msg, JS.__msgtype__)).hex())
for m in spec["tf"]:
    stamp = T(sec=m["sec"], nanosec=m["nanosec"])
    transforms = [TS(header=H(stamp=stamp, frame_id=m["parent"]), child_frame_id=t[0],
                     transform=TR(translation=V3(x=t[1], y=t[2], z=t[3]),
                                  rotation=Q(x=t[4], y=t[5], z=t[6], w=t[7])))
                  for t in m["transforms"]]
    out["tf"].append(bytes(ts.serialize_cdr(TF(transforms=transforms), TF.__msgtype__)).hex())
json.dump(out, sys.stdout)
