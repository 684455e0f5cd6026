"""Writes a ROS 2 MCAP log of `sensor_msgs/msg/JointState` on /joint_states with
`mcap-ros2-support`'s writer (a writer nobody on the tumble team wrote), as a robot's log would
hold them: what `tumble diff` compares a simulated run against.

Usage: write_joint_log.py SPEC.json OUT.mcap, SPEC = {"times_ns": [t, ...],
  "joints": {name: [position at each time, ...]}, "velocity": bool (default false: empty)}
Header stamps are the log times.
Prints {"messages": n} as JSON.
"""
import json
import sys

from mcap_ros2.writer import Writer

JOINT_STATE = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def main(spec_path, out_path):
    spec = json.load(open(spec_path))
    names = list(spec["joints"])
    with open(out_path, "wb") as f:
        writer = Writer(f)
        schema = writer.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE)
        for k, t in enumerate(int(t) for t in spec["times_ns"]):
            stamp = t
            positions = [spec["joints"][n][k] for n in names]
            writer.write_message(
                "/joint_states",
                schema,
                {
                    "header": {"stamp": {"sec": stamp // 1_000_000_000,
                                         "nanosec": stamp % 1_000_000_000},
                               "frame_id": ""},
                    "name": names,
                    "position": positions,
                    "velocity": [0.0] * len(names) if spec.get("velocity") else [],
                    "effort": [],
                },
                log_time=t,
                publish_time=t,
                sequence=k,
            )
        writer.finish()
    json.dump({"messages": len(spec["times_ns"])}, sys.stdout)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
