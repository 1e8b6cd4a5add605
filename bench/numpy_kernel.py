#!/usr/bin/python3
"""Kernel K in NumPy: the user's alternative to isowrench's fast path.

One evaluation = forward kinematics of a serial URDF chain, the 6 x m endpoint Jacobian (world
axes, reference point the endpoint), the muscle torque tau = -F (dL/dtheta)^T from the path
points' Jacobians, and W = S_t J (J^T S_t J + S_p)^-1 tau (MODEL.md "Statics"). Run
vectorised over many postures (batched matmul + np.linalg.solve) and as a per-posture loop;
prints microseconds per posture for both, and W at the nominal posture to compare with
`isowrench wrench`.

    /usr/bin/python3 bench/numpy_kernel.py [urdf] [--postures 100000] [--loop 2000]

Uses Debian's python3-numpy. Note: np.linalg.solve raises LinAlgError for the WHOLE batch when
a single K is singular (e.g. a straight knee); the postures here avoid that.
"""

import argparse
import math
import os
import time
import xml.etree.ElementTree as ET

import numpy as np

NS = "{urn:isowrench:urdf:1}"


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def floats(text, default):
    return [float(v) for v in text.split()] if text is not None and text.strip() else default


def load(path):
    """A serial chain from the URDF: movable joints with fixed joints folded in."""
    root = ET.parse(path).getroot()
    stiffness = {e.get("name"): float(e.get("stiffness", "0")) for e in root.findall(NS + "joint")}
    joints, link_frame = [], {}
    root_link = None
    pending = np.eye(4)
    for j in root.findall("joint"):
        parent, child = j.find("parent").get("link"), j.find("child").get("link")
        if root_link is None:
            root_link = parent
            link_frame[parent] = (-1, np.eye(4))
        o = j.find("origin")
        T = np.eye(4)
        if o is not None:
            T[:3, :3] = rpy_matrix(*floats(o.get("rpy"), [0, 0, 0]))
            T[:3, 3] = floats(o.get("xyz"), [0, 0, 0])
        kind = j.get("type")
        if kind == "fixed":
            pending = pending @ T
            link_frame[child] = (len(joints) - 1, pending.copy())
            continue
        T = pending @ T
        axis = np.array(floats(j.find("axis").get("xyz") if j.find("axis") is not None else None, [1, 0, 0]))
        joints.append(dict(name=j.get("name"), T=T, axis=axis / np.linalg.norm(axis),
                           revolute=kind in ("revolute", "continuous"),
                           stiffness=stiffness.get(j.get("name"), 0.0)))
        pending = np.eye(4)
        link_frame[child] = (len(joints) - 1, np.eye(4))
    t = root.find(NS + "transducer")
    endpoint = pending @ np.array(floats(t.get("xyz"), [0, 0, 0]) + [1.0])
    s_t = np.array(floats(t.get("stiffness"), [1e7] * 6))
    for dof in (t.get("released") or "").split():
        s_t[["x", "y", "z", "rx", "ry", "rz"].index(dof)] = 0.0
    m = root.find(NS + "muscle")
    points = []
    for p in m.findall(NS + "point"):
        frame, offset = link_frame[p.get("link")]
        points.append((frame, (offset @ np.array(floats(p.get("xyz"), [0, 0, 0]) + [1.0]))[:3]))
    nominal = np.zeros(len(joints))
    names = [j["name"] for j in joints]
    for p in root.findall(NS + "posture"):
        nominal[names.index(p.get("joint"))] = math.radians(float(p.get("degrees")))
    return dict(joints=joints, endpoint=endpoint[:3], s_t=s_t, points=points, force=float(m.get("max_force")),
                s_p=np.array([j["stiffness"] for j in joints]), nominal=nominal, names=names)


def rodrigues(axis, q):
    """Rotation matrices (N, 3, 3) about a fixed unit axis by angles q (N,)."""
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * (K @ K)


def kernel(model, Q):
    """W (N, 6) for postures Q (N, m): the whole batch at once."""
    N, m = Q.shape
    R = np.broadcast_to(np.eye(3), (N, 3, 3))
    o = np.zeros((N, 3))
    Rs, os_, zs = [], [], []
    for k, j in enumerate(model["joints"]):
        o = o + R @ j["T"][:3, 3]
        R = R @ j["T"][:3, :3]
        z = R @ j["axis"]
        if j["revolute"]:
            R = R @ rodrigues(j["axis"], Q[:, k])
        else:
            o = o + z * Q[:, k:k + 1]
        Rs.append(R)
        os_.append(o)
        zs.append(z)
    z = np.stack(zs, axis=2)              # (N, 3, m)
    origins = np.stack(os_, axis=2)       # (N, 3, m)
    revolute = np.array([j["revolute"] for j in model["joints"]])
    pE = R @ model["endpoint"] + o
    J = np.zeros((N, 6, m))
    J[:, :3, :] = np.where(revolute, np.cross(z, pE[:, :, None] - origins, axis=1), z)
    J[:, 3:, :] = np.where(revolute, z, 0.0)

    def point(frame, offset):
        if frame < 0:
            return np.broadcast_to(offset, (N, 3)), np.zeros((N, 3, m))
        x = Rs[frame] @ offset + os_[frame]
        Jp = np.where(revolute, np.cross(z, x[:, :, None] - origins, axis=1), z)
        Jp[:, :, frame + 1:] = 0.0
        return x, Jp

    pts = [point(f, p) for f, p in model["points"]]
    dL = np.zeros((N, m))
    for (x0, J0), (x1, J1) in zip(pts, pts[1:]):
        u = x1 - x0
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        dL += np.einsum("ni,nij->nj", u, J1 - J0)
    tau = -model["force"] * dL
    SJ = model["s_t"][None, :, None] * J
    K = np.transpose(J, (0, 2, 1)) @ SJ + np.diag(model["s_p"])
    dtheta = np.linalg.solve(K, tau[:, :, None])
    return (SJ @ dtheta)[:, :, 0]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("urdf", nargs="?", default=os.path.join(here, "..", "urdf", "rat_hindlimb_5dof_base.urdf"))
    parser.add_argument("--postures", type=int, default=100000)
    parser.add_argument("--loop", type=int, default=2000)
    args = parser.parse_args()
    model = load(args.urdf)
    m = len(model["joints"])
    rng = np.random.default_rng(2026)
    prismatic = np.array([not j["revolute"] for j in model["joints"]])
    Q = model["nominal"] + np.where(prismatic, 1e-3, 1.047) * rng.uniform(-1, 1, (args.postures, m))

    W0 = kernel(model, model["nominal"][None, :])[0]
    print(f"NumPy {np.__version__}, {os.path.basename(args.urdf)} (m = {m})")
    print("W at the nominal posture: [" + " ".join(f"{v:.6g}" for v in W0[:3]) + "] N, [" +
          " ".join(f"{v:.6g}" for v in W0[3:]) + "] N·m")
    kernel(model, Q[:1000])  # warm-up
    t0 = time.perf_counter()
    W = kernel(model, Q)
    t1 = time.perf_counter()
    assert np.all(np.isfinite(W))
    n = min(args.loop, args.postures)
    t2 = time.perf_counter()
    for i in range(n):
        kernel(model, Q[i:i + 1])
    t3 = time.perf_counter()
    print(f"vectorised over {args.postures} postures: {(t1 - t0) / args.postures * 1e6:.2f} us/posture")
    print(f"per-posture loop over {n} postures:      {(t3 - t2) / n * 1e6:.1f} us/posture")


if __name__ == "__main__":
    main()
