#!/usr/bin/env python3
"""Moment arms of an imported model against central differences of its own lengths.

Usage: real_model_check.py ISOWRENCH_BINARY MODEL.urdf POSTURES

Runs `isowrench kinematics --json` at POSTURES random postures, uniform over each coordinate's
range (the URDF <limit> of its joint or the lower/upper of its isowrench:coordinate; +-60 deg
when unbounded), the first two with every coordinate 5 deg beyond its lower and upper end, and
compares every muscle's moment arm with -(L(q + h) - L(q - h)) / 2h, h = 0.001 deg. Prints the
worst difference. Used for the "Real models" section of docs/opensim.md; the models themselves
are not in the repository. Prismatic coordinates are not perturbed (rat and human limbs have
none on the chain).
"""
import json
import math
import random
import subprocess
import sys
import xml.etree.ElementTree as ET

cli, urdf, count = sys.argv[1], sys.argv[2], int(sys.argv[3])
extra = sys.argv[4:]  # more options of `isowrench kinematics`, e.g. --wrap exact
H = 1e-3  # degrees


def kinematics(postures, names):
    with open("/tmp/real_model_check.csv", "w") as f:
        f.write(",".join(names) + "\n")
        for p in postures:
            f.write(",".join("%.17g" % p[n] for n in names) + "\n")
    out = subprocess.run([cli, "kinematics", urdf, "--postures", "/tmp/real_model_check.csv",
                          "--json", *extra], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)["postures"]


names = json.loads(subprocess.run([cli, "kinematics", urdf, "--json"], capture_output=True,
                                  text=True, check=True).stdout)["coordinates"]
root = ET.parse(urdf).getroot()
ranges = {n: (-60.0, 60.0) for n in names}
for joint in root.iter("joint"):
    limit = joint.find("limit")
    if joint.get("name") in ranges and limit is not None and joint.get("type") == "revolute":
        ranges[joint.get("name")] = (math.degrees(float(limit.get("lower"))),
                                     math.degrees(float(limit.get("upper"))))
for c in root.iter("{urn:isowrench:urdf:1}coordinate"):
    if c.get("name") in ranges and c.get("lower") and c.get("upper"):
        ranges[c.get("name")] = (math.degrees(float(c.get("lower"))),
                                 math.degrees(float(c.get("upper"))))

random.seed(1)
base = [{n: random.uniform(*ranges[n]) for n in names} for _ in range(count)]
for n in names:
    base[0][n] = ranges[n][0] - 5.0
    base[1][n] = ranges[n][1] + 5.0
rows = []
for p in base:
    rows.append(p)
    for n in names:
        for s in (1, -1):
            q = dict(p)
            q[n] += s * H
            rows.append(q)
results = kinematics(rows, names)
per = 1 + 2 * len(names)
worst, where, checked = 0.0, None, 0
for i in range(len(base)):
    at = results[i * per]
    for j, n in enumerate(names):
        plus, minus = results[i * per + 1 + 2 * j], results[i * per + 2 + 2 * j]
        for muscle, value in at["muscles"].items():
            fd = -(plus["muscles"][muscle]["length_m"] -
                   minus["muscles"][muscle]["length_m"]) / (2 * math.radians(H))
            error = abs(fd - value["moment_arm_m"][j])
            checked += 1
            if error > worst:
                worst, where = error, "posture %d, %s about %s" % (i, muscle, n)
print("%d postures (2 beyond every range end), %d muscles, %d moment arms: worst "
      "|r - (-dL/dq) by differences| = %.2g m (%s)"
      % (len(base), len(results[0]["muscles"]), checked, worst, where))
