"""Finds the URDF corpora shipped in the pip packages `example-robot-data` and `pybullet`
(installed in the test venv) and counts, per file, what an independent XML reader sees:
links, links without <inertial>, links whose <mass value> is 0. Prints JSON:

{"roots": {"example-robot-data": dir, "pybullet": dir, "package_path": dir},
 "files": {path: {"links": n, "missing": n, "zero_mass": n[, "leading_whitespace": true]}
           | {"xml_error": "..."}}}

A file expat refuses only because its XML declaration comes after leading whitespace is read
again without that whitespace, as tinyxml2 (urdfdom's XML parser) reads it ("leading_whitespace":
true); tumble loads such files with a warning (docs/urdf.md).
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
                late_declaration = False
                try:
                    robot = ET.parse(path).getroot()
                except ET.ParseError as e:
                    with open(path, "rb") as f:
                        text = f.read()
                    stripped = text.lstrip(b" \t\r\n")
                    if stripped == text or not stripped.startswith(b"<?xml"):
                        files[path] = {"xml_error": str(e)}
                        continue
                    try:
                        robot = ET.fromstring(stripped)
                    except ET.ParseError as e2:
                        files[path] = {"xml_error": str(e2)}
                        continue
                    late_declaration = True
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
                if late_declaration:
                    files[path]["leading_whitespace"] = True
    json.dump({"roots": roots, "files": files}, sys.stdout)


if __name__ == "__main__":
    main()
