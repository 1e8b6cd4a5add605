#pragma once
// Private: an OpenSim document read into plain structs (osim_reader.cpp), before the chain is
// chosen and the LimbDescription built (osim_import.cpp). Frames and transforms follow
// shared/OPENSIM.md: X_parentbody_childbody(q) = X_Pb_P * X_PC(q) * X_Cb_C^-1.

#include <tinyxml2.h>

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "isowrench/function.hpp"
#include "isowrench/muscle.hpp"

namespace isowrench::osim {

/// One of the six TransformAxis entries (or the fixed axes of a PinJoint, ...).
struct Axis {
  std::string name;  // rotation1..3, translation1..3
  bool rotation = true;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit, in the parent frame P (rotations:
                                                    // body-fixed sequence)
  std::string coordinate;                           // "" for an axis that depends on no coordinate
  Function function;  // value of the axis (rad or m) as a function of the coordinate
  int line = 0;
};

struct Coordinate {
  std::string name;
  std::string joint;
  double default_value = 0.0;
  // OpenSim's default range when <range> is absent (Coordinate::constructProperties).
  double lower = -10.0;
  double upper = 10.0;
  bool locked = false;
  bool rotational = true;
  int line = 0;
};

struct Joint {
  std::string name;
  std::string type;  // CustomJoint, PinJoint, ...
  int line = 0;
  std::string parent_body, child_body;
  Eigen::Isometry3d X_Pb_P = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d X_Cb_C = Eigen::Isometry3d::Identity();
  std::vector<std::string> coordinates;  // declaration order
  std::vector<Axis> axes;                // rotations first (body-fixed order), then translations
};

struct Point {
  std::string name;
  std::string type;  // PathPoint, MovingPathPoint, ConditionalPathPoint
  int line = 0;
  std::string body;
  Eigen::Isometry3d X_body_frame = Eigen::Isometry3d::Identity();  // socket frame in its body
  Eigen::Vector3d location = Eigen::Vector3d::Zero();              // m, in the socket frame
  // MovingPathPoint: component i = functions[i](clamp(q_coordinates[i], coordinate range)),
  // or the function at 0 when no coordinate is named (OpenSim MovingPathPoint::getLocation);
  // the three coordinates are equal (OpenSim refuses others). `location` is unused.
  bool moving = false;
  Function functions[3];
  std::string moving_coordinates[3];
  // ConditionalPathPoint: active while range[0] - 1e-5 <= q <= range[1] + 1e-5.
  bool conditional = false;
  std::string condition_coordinate;
  double range[2] = {0.0, 0.0};
};

/// A wrap object of a body's WrapObjectSet (Simulation/Wrap/WrapObject.h and its subclasses).
struct WrapObject {
  std::string name;
  std::string type;  // WrapCylinder, WrapSphere, WrapEllipsoid, WrapTorus, WrapCylinderObst, ...
  std::string body;
  int line = 0;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();        // in the body frame
  Eigen::Vector3d xyz_body_rotation = Eigen::Vector3d::Zero();  // body-fixed X-Y-Z
  bool active = true;
  std::string quadrant = "all";
  // OpenSim's defaults (constructProperties): cylinder radius 1, length 1; sphere radius 1;
  // ellipsoid dimensions 0.05; torus inner 0.01, outer 0.05.
  double radius = 1.0;
  double length = 1.0;
  Eigen::Vector3d dimensions = Eigen::Vector3d::Constant(0.05);
  double inner_radius = 0.01;
  double outer_radius = 0.05;
};

/// A PathWrap of a GeometryPath's PathWrapSet (Simulation/Wrap/PathWrap.cpp).
struct PathWrap {
  std::string object;
  std::string method = "hybrid";
  int range[2] = {-1, -1};  // 1-based PathPointSet indices, < 1 = first/last
  int line = 0;
};

struct Muscle {
  std::string name;
  std::string type;
  int line = 0;
  double max_force = 0.0;
  std::vector<Point> points;
  std::vector<PathWrap> wraps;  // its PathWrapSet, in order
  // Force model and parameters (Thelen2003Muscle, Millard2012EquilibriumMuscle; constant for
  // other types, with force_note saying so). Properties missing from the muscle come from the
  // document's <defaults> object of its type, else OpenSim's class defaults.
  MuscleForceSpec force;
  std::string force_note;
};

/// CoordinateCouplerConstraint: q_dependent = scale * f(q_independent).
struct Coupler {
  std::string name;
  std::string dependent, independent;
  Function function;  // scale folded in
  int line = 0;
};

struct Model {
  std::string source;
  int version = 0;
  std::string name;
  std::string ground = "ground";
  std::string length_units, force_units;
  std::vector<std::string> bodies;  // ground first
  std::map<std::string, int> body_lines;
  std::vector<WrapObject> wrap_objects;  // in document order (the first of a name wins)
  std::vector<Joint> joints;
  std::map<std::string, Coordinate> coordinates;
  std::vector<Muscle> muscles;
  std::vector<Coupler> couplers;
  std::vector<std::string> warnings;
};

/// Read the document. @throws isowrench::Error "source:line: ..." (see opensim.hpp).
Model ReadModel(const std::string& xml, const std::string& source);

/// X_Pb_Cb of a joint at coordinate values `q` (missing coordinates at their default).
Eigen::Isometry3d JointTransform(const Model& model, const Joint& joint,
                                 const std::map<std::string, double>& q);

/// Rigid motion of one axis by `value` (rad or m).
Eigen::Isometry3d AxisMotion(const Axis& axis, double value);

/// Body-fixed X-Y-Z rotation (Simbody Rotation::setRotationToBodyFixedXYZ).
Eigen::Matrix3d BodyFixedXyz(const Eigen::Vector3d& angles);

}  // namespace isowrench::osim
