#pragma once
/// @file
/// Umbrella header: include this to use the whole isowrench library.
///
///   #include <isowrench/isowrench.hpp>
///   isowrench::Model model = isowrench::Model::FromUrdfFile("urdf/rat_hindlimb_5dof.urdf");
///   auto eval = isowrench::EvaluateWrench(model, model.nominal_posture(), "GP");
///   // eval.statics.wrench: [fx fy fz mx my mz] in N and N·m, applied by the limb to the
///   // transducer, in transducer axes.

#include "isowrench/conventions.hpp"
#include "isowrench/diagnostics.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"
#include "isowrench/identification.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"
#include "isowrench/paper.hpp"
#include "isowrench/plots.hpp"
#include "isowrench/posture.hpp"
#include "isowrench/statics.hpp"
#include "isowrench/wrap.hpp"
