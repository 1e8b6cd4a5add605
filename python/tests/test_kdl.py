"""The endpoint Jacobian equals PyKDL's, with the KDL chain built here from the same URDF.

kdl_parser_py is not in Debian, so the chain is built by hand, the way kdl_parser does it: one
KDL segment per URDF joint, whose joint sits at the joint origin (in the parent link frame) with
its axis rotated into the parent frame, and whose tip frame is the joint origin. Then a fixed
segment to the endpoint (<isowrench:transducer xyz rpy>). KDL's ChainJntToJacSolver gives the
Jacobian in the base (world) frame with the reference point at the tip: the module's
kinematics()["jacobian"] convention.
"""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import isowrench

from conftest import URDF

PyKDL = pytest.importorskip("PyKDL")

NS = "{urn:isowrench:urdf:1}"


def frame(element):
    """KDL frame of an <origin xyz rpy> (or transducer xyz/rpy attributes)."""
    xyz = [float(v) for v in (element.get("xyz") or "0 0 0").split()] if element is not None else [0, 0, 0]
    rpy = [float(v) for v in (element.get("rpy") or "0 0 0").split()] if element is not None else [0, 0, 0]
    return PyKDL.Frame(PyKDL.Rotation.RPY(*rpy), PyKDL.Vector(*xyz))


def kdl_chain(path):
    root = ET.parse(path).getroot()
    joints = {j.find("child").get("link"): j for j in root.findall("joint")}
    tip = root.find(NS + "transducer")
    link, order = tip.get("link"), []
    while link in joints:
        order.append(joints[link])
        link = joints[link].find("parent").get("link")
    chain, names = PyKDL.Chain(), []
    for j in reversed(order):
        origin = frame(j.find("origin"))
        kind = j.get("type")
        if kind == "fixed":
            joint = PyKDL.Joint(j.get("name"), PyKDL.Joint.Fixed)
        else:
            axis = origin.M * PyKDL.Vector(*[float(v) for v in (j.find("axis").get("xyz") or "1 0 0").split()])
            joint_type = PyKDL.Joint.TransAxis if kind == "prismatic" else PyKDL.Joint.RotAxis
            joint = PyKDL.Joint(j.get("name"), origin.p, axis, joint_type)
            names.append(j.get("name"))
        chain.addSegment(PyKDL.Segment(j.find("child").get("link"), joint, origin))
    chain.addSegment(PyKDL.Segment("endpoint", PyKDL.Joint("endpoint", PyKDL.Joint.Fixed), frame(tip)))
    return chain, names


def kdl_jacobian(chain, q):
    solver = PyKDL.ChainJntToJacSolver(chain)
    joints = PyKDL.JntArray(len(q))
    for i, v in enumerate(q):
        joints[i] = float(v)
    jac = PyKDL.Jacobian(len(q))
    assert solver.JntToJac(joints, jac) >= 0
    tip = PyKDL.Frame()
    PyKDL.ChainFkSolverPos_recursive(chain).JntToCart(joints, tip)
    J = np.array([[jac[r, c] for c in range(len(q))] for r in range(6)])
    return J, np.array([tip.p[i] for i in range(3)])


# Models whose coordinates are their joints (the coupled knee's columns are coordinates, J C).
# Postures drawn beyond the base dofs' limits on purpose: their plausibility warnings are expected.
@pytest.mark.filterwarnings("ignore:.*outside the joint's limits:UserWarning")
@pytest.mark.parametrize("name", ["rat_hindlimb_5dof.urdf", "rat_hindlimb_6dof.urdf",
                                  "rat_hindlimb_5dof_base.urdf", "planar_2r.urdf", "planar_4r.urdf"])
def test_jacobian_equals_pykdl(name):
    m = isowrench.load(str(URDF / name))
    chain, names = kdl_chain(URDF / name)
    assert names == m.coordinates
    rng = np.random.default_rng(11)
    for q in [m.default_posture] + list(rng.uniform(-np.pi, np.pi, size=(50, len(names)))):
        k = m.kinematics(q)
        J, endpoint = kdl_jacobian(chain, q)
        np.testing.assert_allclose(k["endpoint_m"], endpoint, rtol=0, atol=1e-12)
        np.testing.assert_allclose(k["jacobian"], J, rtol=0, atol=1e-12)
