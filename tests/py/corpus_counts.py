"""Finds the URDF corpora shipped in the pip packages `example-robot-data` and `pybullet`
(installed in the test venv) and counts, per file, what an independent XML reader sees:
links, links without <inertial>, links whose <mass value> is 0. Prints JSON:

{"roots": {"example-robot-data": dir, "pybullet": dir, "package_path": dir},
 "files": {path: {"links": n, "missing": n, "zero_mass": n} | {"xml_error": "..."}}}
"""
import json
import os
import sys
import sysconfig
import xml.etree.ElementTree as ET

import pybullet_data


def main():
    purelib = sysconfig.get_paths()["purelib"]
    share = os.path.join(purelib, "cmeel.prefix", "share")
    erd = os.path.join(share, "example-robot-data", "robots")
    if not os.path.isdir(erd):
        sys.exit(f"example-robot-data robots not found at {erd}")
    roots = {"example-robot-data": erd, "pybullet": pybullet_data.getDataPath(), "package_path": share}
    files = {}
    for key in ("example-robot-data", "pybullet"):
        for dirpath, _, names in os.walk(roots[key]):
            for name in names:
                if not name.lower().endswith(".urdf"):
                    continue
                path = os.path.join(dirpath, name)
                try:
                    robot = ET.parse(path).getroot()
                except ET.ParseError as e:
                    files[path] = {"xml_error": str(e)}
                    continue
                links = robot.findall("link")
                missing = sum(1 for l in links if l.find("inertial") is None)
                zero = 0
                for l in links:
                    mass = l.find("inertial/mass")
                    if mass is not None:
                        try:
                            zero += float(mass.get("value", "nan")) == 0.0
                        except ValueError:
                            pass
                files[path] = {"links": len(links), "missing": missing, "zero_mass": zero}
    json.dump({"roots": roots, "files": files}, sys.stdout)


if __name__ == "__main__":
    main()
