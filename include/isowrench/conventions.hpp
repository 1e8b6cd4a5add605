#pragma once
/// @file
/// Documentation only: the units, frames, vector orders and notation used by every isowrench
/// header. See docs/model.md for the argument.
///
/// Units
/// -----
/// The library is SI throughout: metres, radians, newtons (N), newton-metres (N·m),
/// N/m for translational stiffness, N·m/rad for rotational stiffness. The CLI accepts degrees
/// for postures and says so; it converts at the boundary.
///
/// 6-vectors (KDL order)
/// ---------------------
///  - twist / Jacobian rows / endpoint displacement: [vx vy vz wx wy wz] (linear first);
///  - wrench: [fx fy fz mx my mz], the moment taken about the endpoint origin.
///  - transducer stiffness diagonal S_t: [kx ky kz krx kry krz], in the transducer's axes.
///  - dof names used on the command line and in URDF tags: x y z rx ry rz.
///
/// Frames
/// ------
///  - W (world = the URDF root link, "ground"): J_W_E is expressed here.
///  - E (endpoint): a point fixed on the distal link; the reference point of J and of moments.
///  - T (transducer): the axes the transducer measures in. Fixed in world by default
///    (R_W_T); S_t is diagonal in T; the wrench is reported in T and in W.
///
/// Sign of the wrench
/// ------------------
/// W is the wrench the limb applies TO the transducer (what the transducer reads). The
/// paper's F (Eq. 10) is -W. Joint torques: tau_muscle = -F_muscle * (dL/dtheta)^T, so a
/// muscle that shortens when a joint turns produces positive torque about it. Equilibrium:
/// J^T W + S_p dtheta = tau_muscle.
///
/// Notation
/// --------
///  J      6 x m endpoint Jacobian (J_W_E in world axes, J_T_E in transducer axes)
///  S_t    6 x 6 diagonal transducer-attachment stiffness (in T)
///  S_p    m x m diagonal joint stiffness (passive joints, extra dofs, base translations)
///  K      J^T S_t J + S_p, the limb's stiffness seen at the joints
///  dtheta K^-1 tau: the small joint displacement at equilibrium (rad or m per joint)
///  q      posture: joint positions in chain order (rad for revolute, m for prismatic)
