#pragma once
/// @file
/// The paper's Figure 2, 3 and 4 conditions recomputed from the shipped rat URDFs.
/// Each panel is one generalized force (a wrench) under one set of conditions. Stiffness values
/// the paper leaves unstated are chosen here and printed with every panel (docs/paper.md).

#include <string>
#include <vector>

#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {

/// One panel of a paper figure.
struct PaperPanel {
  int figure = 0;         ///< 2, 3 or 4
  std::string row;        ///< "A".."F"
  std::string column;     ///< "released rz (5 forces)" / "over-constrained (6 forces)" / ""
  std::string condition;  ///< human-readable, with the stiffness values and units
  std::string method;     ///< "Eq. 10", "J^-T tau (Eq. 11)", "pinv (Eq. 15)", "femur removed"
  Vector6d s_t = Vector6d::Zero();     ///< S_t used (N/m, N·m/rad), 0 for released / not used
  double base_stiffness = 0.0;         ///< N/m, 0 = rigid base (no base dofs)
  Vector6d wrench = Vector6d::Zero();  ///< W in transducer (world) axes, N and N·m
  bool valid = true;                   ///< small-motion rule holds (Eq. 10 panels only)
  std::string note;                    ///< status / validity message, empty when nothing to say
};

/// Compute the panels of figure 2, 3 or 4 from the URDFs in `urdf_dir`
/// (rat_hindlimb_5dof.urdf, rat_hindlimb_6dof.urdf). @throws Error for other figure numbers or
/// missing files.
std::vector<PaperPanel> ComputePaperFigure(int figure, const std::string& urdf_dir);

/// The femur-removed wrench: the tibia held only by the transducer and pulled directly by the
/// muscle. W = [F u; (p_insertion - p_E) x F u] in transducer axes, u the unit vector from the
/// insertion toward the previous path point.
Vector6d FemurRemovedWrench(const Model& model, const Eigen::VectorXd& q, const std::string& muscle,
                            double activation = 1.0);

/// Directory of the shipped URDFs: $ISOWRENCH_URDF_DIR if set, else the source tree's urdf/
/// when it still exists, else <dir of the running program>/../share/isowrench/urdf (an
/// installed tool, wherever its prefix was moved), else the configured install directory.
std::string DefaultUrdfDirectory();

}  // namespace isowrench
