// Importing OpenSim wrap objects and PathWraps (src/opensim): every shape, OpenSim's defaults,
// a wrap on a body above the clamp baked into the ground, ranges renumbered, bad input refused.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "isowrench/error.hpp"
#include "isowrench/kinematics.hpp"
#include "isowrench/opensim.hpp"
#include "isowrench/wrap.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;

std::string ReadWrapsFixture() {
  std::ifstream in(std::string(ISOWRENCH_TEST_OSIM_DIR) + "/wraps.osim");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

OpenSimImport ImportWraps(const std::string& xml) {
  OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "foot";
  return ImportOpenSimString(xml, "wraps.osim", options);
}

const WrapObjectSpec& Object(const LimbDescription& d, const std::string& name) {
  for (const WrapObjectSpec& w : d.wrap_objects) {
    if (w.name == name) return w;
  }
  throw Error("no wrap object " + name);
}

TEST(WrapImportTest, EveryShapeIsImportedWithItsFrameQuadrantAndRange) {
  const OpenSimImport import = ImportWraps(ReadWrapsFixture());
  const LimbDescription& d = import.description;
  for (const std::string& w : import.warnings) {
    EXPECT_THAT(w, ::testing::Not(HasSubstr("wrap"))) << w;
  }
  // The pelvis is the clamp: its cylinder stays on it, in its own frame.
  const WrapObjectSpec& hip = Object(d, "hip_cyl");
  EXPECT_EQ(hip.link, "pelvis");
  EXPECT_EQ(hip.translation, Eigen::Vector3d(0.004, -0.002, 0.001));
  EXPECT_EQ(hip.xyz_body_rotation, Eigen::Vector3d(0.3, -0.2, 0.5));
  EXPECT_EQ(hip.quadrant.ToString(), "-x");
  EXPECT_EQ(hip.radius, 0.002);
  EXPECT_EQ(hip.length, 0.02);
  // Femur objects keep their own frames.
  const WrapObjectSpec& condyle = Object(d, "condyle");
  EXPECT_EQ(condyle.link, "femur");
  EXPECT_EQ(condyle.shape, WrapShape::kEllipsoid);
  EXPECT_EQ(condyle.radii, Eigen::Vector3d(0.002, 0.003, 0.0025));
  EXPECT_EQ(condyle.quadrant.ToString(), "+y");
  const WrapObjectSpec& ring = Object(d, "ring");
  EXPECT_EQ(ring.shape, WrapShape::kTorus);
  EXPECT_EQ(ring.inner_radius, 0.001);
  EXPECT_EQ(ring.outer_radius, 0.004);
  EXPECT_EQ(ring.xyz_body_rotation, Eigen::Vector3d(1.5707963, 0, 0));
  EXPECT_FALSE(Object(d, "knee_ball").active);
  // GAS: three points (the middle one conditional), three wraps in order.
  const MuscleSpec& gas = d.muscles[2];
  ASSERT_EQ(gas.name, "GAS");
  ASSERT_EQ(gas.wraps.size(), 3u);
  EXPECT_EQ(gas.wraps[0].object, "condyle");
  EXPECT_EQ(gas.wraps[0].method, WrapMethod::kAxial);
  EXPECT_EQ(gas.wraps[0].range_first, 2);
  EXPECT_EQ(gas.wraps[0].range_last, 3);
  EXPECT_EQ(gas.wraps[1].method, WrapMethod::kMidpoint);
  EXPECT_EQ(gas.wraps[2].range_first, -1);
  EXPECT_THAT(FormatOpenSimReport(import), HasSubstr("wraps over condyle, ring, knee_ball"));
  // Clamped at the femur, the pelvis is above the clamp: its cylinder is fixed in the world at
  // the pelvis's baked pose, the same pose GM's pelvis point gets.
  OpenSimImportOptions femur;
  femur.clamp_body = "femur";
  femur.endpoint_body = "foot";
  const OpenSimImport baked = ImportOpenSimString(ReadWrapsFixture(), "wraps.osim", femur);
  const WrapObjectSpec& world = Object(baked.description, "hip_cyl");
  EXPECT_EQ(world.link, baked.description.root_link);
  const Eigen::Isometry3d X_G_pelvis = world.Pose() * hip.Pose().inverse();
  const PathPoint& gm0 = baked.description.muscles[0].path[0];
  ASSERT_EQ(gm0.link, baked.description.root_link);
  EXPECT_LT((X_G_pelvis * Eigen::Vector3d(0.01, 0.005, 0.002) - gm0.position).norm(), 1e-15);
  EXPECT_LT((X_G_pelvis.linear().transpose() * X_G_pelvis.linear() - Eigen::Matrix3d::Identity())
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
  // The result writes and reads back, and builds a Model (which warns, once, that wraps are not
  // evaluated yet).
  const LimbDescription again = ReadUrdfString(WriteUrdfString(d), "wraps.urdf");
  EXPECT_EQ(again.wrap_objects.size(), d.wrap_objects.size());
  EXPECT_NO_THROW(Model{again});
}

void ExpectImportError(const std::string& from, const std::string& to, const std::string& text) {
  std::string xml = ReadWrapsFixture();
  const size_t at = xml.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  for (size_t at2 = at; at2 != std::string::npos; at2 = xml.find(from, at2 + to.size())) {
    xml.replace(at2, from.size(), to);
  }
  try {
    ImportWraps(xml);
    ADD_FAILURE() << "no error; expected " << text;
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(text));
  }
}

TEST(WrapImportTest, BadWrapsAreRefusedWithFileLineMuscleAndObject) {
  ExpectImportError("<wrap_object>condyle</wrap_object>", "<wrap_object>condyl</wrap_object>",
                    "muscle 'GAS' PathWrap 'condyl': no body has a wrap object of that name");
  ExpectImportError("WrapTorus", "WrapCylinderObst",
                    "muscle 'GAS' PathWrap 'ring' wraps over WrapCylinderObst 'ring' on 'femur': "
                    "WrapCylinderObst and WrapDoubleCylinderObst are not supported yet");
  ExpectImportError("<inner_radius>0.001</inner_radius>", "<inner_radius>0.005</inner_radius>",
                    "WrapTorus 'ring' on 'femur': inner_radius 0.005 m is not below outer_radius");
  ExpectImportError("<radius>0.002</radius><length>0.02</length>",
                    "<radius>-0.002</radius><length>0.02</length>",
                    "WrapCylinder 'hip_cyl' on 'pelvis': radius -0.002 m must be > 0");
  ExpectImportError("<range>2 3</range>", "<range>2 4</range>",
                    "muscle 'GAS' PathWrap 'condyle': range 2 4 is outside the path's 3 points");
  ExpectImportError("<method>axial</method>", "<method>fan</method>",
                    "method 'fan' is not one of hybrid, midpoint, axial");
  ExpectImportError("<quadrant>+y</quadrant>", "<quadrant>up</quadrant>",
                    "quadrant 'up' is not one of all");
  // Each message starts with the file and the line.
  ExpectImportError("<range>2 3</range>", "<range>2 4</range>", "wraps.osim:");
}

// The published rat hindlimb (not in the repository: no licence), when present: every wrap of
// the chain's muscles is imported, none warned about.
TEST(WrapImportTest, RatHindlimbImportsEveryWrap) {
  const std::string path = "/work/ext/RatHindlimb/models/osim/rat_hindlimb.osim";
  if (!std::ifstream(path)) GTEST_SKIP() << path << " is not here";
  OpenSimImportOptions options;
  options.clamp_body = "pelvis_r";
  options.endpoint_body = "foot_r";
  const OpenSimImport import = ImportOpenSimFile(path, options);
  size_t wraps = 0;
  for (const MuscleSpec& m : import.description.muscles) wraps += m.wraps.size();
  EXPECT_EQ(wraps, 39u);
  for (const std::string& w : import.warnings) {
    EXPECT_THAT(w, ::testing::Not(HasSubstr("wrap"))) << w;
  }
  EXPECT_NO_THROW(Model{import.description});
}

}  // namespace
}  // namespace isowrench

namespace isowrench {
namespace {

// The lengths OpenSim 4.4.1 recorded for Rajagopal's subject_walk_armless_18musc (opensim-core
// OpenSim/Tests/Wrapping/std_testGeometryPathWrapping_subject_walk_armless_muscle_lengths.sto,
// the coordinates of OpenSim/Moco/Test/subject_walk_armless_coordinates.mot; testGeometryPath-
// Wrapping.cpp "Muscle lengths" asserts them to 1e-6 m): its right-leg muscles with cylinder
// wraps (one muscle over two, one with a range and a quadrant), evaluated by ComputeWrappedPath
// on the imported model's kinematics. Skipped when opensim-core's files are not here.
TEST(WrapImportTest, OpenSimMatchesOpenSimsRecordedRajagopalLengths) {
  const std::string core = "/work/ext/opensim-core/OpenSim";
  const std::string osim = core + "/Moco/Test/subject_walk_armless_18musc.osim";
  const std::string mot = core + "/Moco/Test/subject_walk_armless_coordinates.mot";
  const std::string sto =
      core + "/Tests/Wrapping/std_testGeometryPathWrapping_subject_walk_armless_muscle_lengths.sto";
  if (!std::ifstream(osim) || !std::ifstream(mot) || !std::ifstream(sto)) {
    GTEST_SKIP() << "opensim-core's test files are not here";
  }
  OpenSimImportOptions options;
  options.clamp_body = "pelvis";
  options.endpoint_body = "calcn_r";
  const Model model(ImportOpenSimFile(osim, options).description);
  Data data(model);
  auto table = [](const std::string& path, const std::string& first_header) {
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line) && line.rfind(first_header, 0) != 0) {
    }
    std::vector<std::string> header;
    std::stringstream hs(line);
    for (std::string h; hs >> h;) header.push_back(h);
    std::vector<std::vector<double>> rows;
    while (std::getline(in, line)) {
      std::stringstream ls(line);
      std::vector<double> row;
      for (double v; ls >> v;) row.push_back(v);
      if (row.size() == header.size()) rows.push_back(row);
    }
    return std::make_pair(header, rows);
  };
  const auto [coordinate_names, postures] = table(mot, "time");
  const auto [length_names, lengths] = table(sto, "time");
  ASSERT_EQ(postures.size(), lengths.size());
  double worst = 0.0, worst_multi = 0.0;
  int compared = 0, multi_engaged = 0;
  for (size_t row = 0; row < postures.size(); row += 7) {
    Eigen::VectorXd q(model.dof_count());
    for (int c = 0; c < model.dof_count(); ++c) {
      const auto at =
          std::find(coordinate_names.begin(), coordinate_names.end(), model.joint_names()[c]);
      ASSERT_NE(at, coordinate_names.end()) << model.joint_names()[c];
      q[c] = postures[row][at - coordinate_names.begin()] * M_PI / 180.0;  // inDegrees=yes
    }
    for (int i = 0; i < model.muscle_count(); ++i) {
      const MuscleSpec& m = model.muscle(i);
      WrapPathInput in;
      for (const PathPoint& p : m.path) {
        ASSERT_TRUE(p.moving.empty() && p.active_coordinate.empty()) << m.name;
        in.points.push_back(PointPosition(model, data, q, p.link, p.position));
        in.active.push_back(1);
      }
      for (const PathWrapSpec& w : m.wraps) {
        const auto& objects = model.description().wrap_objects;
        const auto o = std::find_if(objects.begin(), objects.end(),
                                    [&](const WrapObjectSpec& s) { return s.name == w.object; });
        WrapPathWrap pw;
        pw.surface = WrapSurface::From(*o);
        const Eigen::Isometry3d X = o->Pose();
        const Eigen::Vector3d origin = PointPosition(model, data, q, o->link, X.translation());
        pw.X_W_S.translation() = origin;
        for (int k = 0; k < 3; ++k) {
          pw.X_W_S.linear().col(k) =
              PointPosition(model, data, q, o->link, X * Eigen::Vector3d::Unit(k)) - origin;
        }
        const int n = static_cast<int>(m.path.size());
        pw.first = w.range_first < 1 ? 0 : w.range_first - 1;
        pw.last = w.range_last < 1 ? n - 1 : w.range_last - 1;
        pw.method = w.method;
        pw.active = o->active;
        pw.object = static_cast<int>(o - objects.begin());
        in.wraps.push_back(pw);
      }
      WrappedPath out;
      ComputeWrappedPath(in, WrapMode::kOpenSim, out);
      const auto column =
          std::find(length_names.begin(), length_names.end(), "/forceset/" + m.name + "|length");
      ASSERT_NE(column, length_names.end()) << m.name;
      const double recorded = lengths[row][column - length_names.begin()];
      // med_gas_r wraps over two cylinders: where both engage, OpenSim's length keeps the
      // tangent points of the first pass with the arcs of the last (Point::getLocationInGround's
      // cache; docs/opensim.md "Wrapping"): 5.6 mm off without that rule.
      if (m.wraps.size() > 1) {
        worst_multi = std::max(worst_multi, std::abs(out.length - recorded));
        multi_engaged += out.wraps[0].wrapped && out.wraps[1].wrapped ? 1 : 0;
      } else {
        worst = std::max(worst, std::abs(out.length - recorded));
      }
      EXPECT_NEAR(out.length, recorded, 1e-6) << m.name << " row " << row;
      ++compared;
    }
  }
  std::cout << compared << " lengths, worst |isowrench - OpenSim| = " << worst
            << " m over the single-wrap muscles, " << worst_multi
            << " m over the two-wrap muscle (both wraps engaged at " << multi_engaged
            << " of its postures)\n";
  EXPECT_GT(compared, 150);
  EXPECT_GT(multi_engaged, 5);  // the postures where the rule matters are among those compared
}

}  // namespace
}  // namespace isowrench
