// Tests of LimbStickFigureSvg (include/isowrench/plots.hpp): joint centres, axes, muscle path
// and endpoint frame are drawn where the rat hindlimb's geometry puts them (MODEL.md: femur
// 31 mm, tibia 41 mm along +x of their frames, hip at the origin, GP origin fixed in world).

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tinyxml2.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/model.hpp"
#include "isowrench/plots.hpp"
#include "svg_test_utils.hpp"

namespace isowrench_test {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// Coordinates are written with 3 decimals: 5e-4 px per coordinate, 1e-3 px for a difference.
constexpr double kDrawingPixelTol = 2e-3;

isowrench::Model Rat() {
  return isowrench::Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) +
                                        "/rat_hindlimb_5dof.urdf");
}

struct View {
  const tinyxml2::XMLElement* g;
  int right, up;
  double scale;
  Eigen::Vector2d origin;
  Eigen::Vector2d Screen(const Eigen::Vector3d& p) const {
    return origin + scale * Eigen::Vector2d(p[right], -p[up]);
  }
};

View ReadView(const tinyxml2::XMLElement* root, const std::string& name) {
  for (const auto* g : ByClass(root, "view")) {
    if (name == g->Attribute("data-view")) {
      auto axis = [](const char* a) {
        return std::string(a) == "x" ? 0 : std::string(a) == "y" ? 1 : 2;
      };
      return {g,
              axis(g->Attribute("data-right")),
              axis(g->Attribute("data-up")),
              Num(g, "data-px-per-m"),
              {Num(g, "data-origin-x"), Num(g, "data-origin-y")}};
    }
  }
  ADD_FAILURE() << "no view " << name;
  return {};
}

const tinyxml2::XMLElement* CentreOf(const View& v, const std::string& joint) {
  for (const auto* c : ByClass(v.g, "joint-centre")) {
    if (std::string(" ") + c->Attribute("data-joints") + " " == " " + joint + " " ||
        std::string(c->Attribute("data-joints")).find(joint) != std::string::npos) {
      return c;
    }
  }
  return nullptr;
}

TEST(LimbStickFigureSvg, TopAndSideViewsPutJointsWhereTheGeometrySays) {
  const isowrench::Model model = Rat();
  const Eigen::VectorXd q = model.nominal_posture();  // hip_rz -110°, knee_rz 105°
  tinyxml2::XMLDocument doc;
  const std::string svg = isowrench::LimbStickFigureSvg(model, q);
  ASSERT_EQ(doc.Parse(svg.c_str()), tinyxml2::XML_SUCCESS) << doc.ErrorStr();
  // Planar chain in x-y: knee at 31 mm along -110°, ankle 41 mm further along -110°+105° = -5°.
  const double hip = -110 * M_PI / 180, knee = hip + 105 * M_PI / 180;
  const Eigen::Vector3d p_knee = 0.031 * Eigen::Vector3d(std::cos(hip), std::sin(hip), 0);
  const Eigen::Vector3d p_ankle =
      p_knee + 0.041 * Eigen::Vector3d(std::cos(knee), std::sin(knee), 0);
  for (const char* name : {"top", "side"}) {
    SCOPED_TRACE(name);
    const View v = ReadView(doc.RootElement(), name);
    ASSERT_GT(v.scale, 0);
    // One circle at the hip holding the three hip joints, one at the knee holding both knee joints.
    const auto centres = ByClass(v.g, "joint-centre");
    ASSERT_EQ(centres.size(), 2u);
    const auto* h = CentreOf(v, "hip_rz");
    const auto* k = CentreOf(v, "knee_rz");
    ASSERT_TRUE(h && k);
    EXPECT_EQ(std::string(h->Attribute("data-joints")), "hip_rz hip_ry hip_rx");
    EXPECT_EQ(std::string(k->Attribute("data-joints")), "knee_rz knee_rx");
    EXPECT_NEAR(
        (Eigen::Vector2d(Num(h, "cx"), Num(h, "cy")) - v.Screen(Eigen::Vector3d::Zero())).norm(), 0,
        kDrawingPixelTol);
    EXPECT_NEAR((Eigen::Vector2d(Num(k, "cx"), Num(k, "cy")) - v.Screen(p_knee)).norm(), 0,
                kDrawingPixelTol);
    // Endpoint frame axes start at the ankle.
    const auto axes = ByClass(v.g, "endpoint-axis");
    ASSERT_EQ(axes.size(), 3u);
    for (const auto* a : axes)
      EXPECT_NEAR((Line(a).a - v.Screen(p_ankle)).norm(), 0, kDrawingPixelTol);
    // Muscle path: the GP origin is fixed in world at (12.67, -10.403, -4.78) mm.
    const auto muscles = ByClass(v.g, "muscle");
    ASSERT_EQ(muscles.size(), 1u);
    EXPECT_STREQ(muscles[0]->Attribute("data-muscle"), "GP");
    const auto points = ByClass(v.g, "muscle-point");
    ASSERT_EQ(points.size(), 2u);
    EXPECT_NEAR((Eigen::Vector2d(Num(points[0], "cx"), Num(points[0], "cy")) -
                 v.Screen(Eigen::Vector3d(0.01267, -0.010403, -0.00478)))
                    .norm(),
                0, kDrawingPixelTol);
  }
}

TEST(LimbStickFigureSvg, JointAxesHaveTheirWorldDirections) {
  const isowrench::Model model = Rat();
  isowrench::LimbDrawingOptions options;
  options.axis_length = 0.01;  // 10 mm
  tinyxml2::XMLDocument doc;
  const std::string svg = isowrench::LimbStickFigureSvg(model, model.nominal_posture(), options);
  ASSERT_EQ(doc.Parse(svg.c_str()), tinyxml2::XML_SUCCESS);
  const View top = ReadView(doc.RootElement(), "top");
  const View side = ReadView(doc.RootElement(), "side");
  auto axis_line = [](const View& v, const std::string& joint) {
    for (const auto* a : ByClass(v.g, "joint-axis")) {
      if (joint == a->Attribute("data-joint")) return Line(a);
    }
    ADD_FAILURE() << "no axis for " << joint;
    return LineGeom{};
  };
  // hip_rz turns about world z: a point in the top view, a vertical 10 mm segment in the side view.
  EXPECT_NEAR(axis_line(top, "hip_rz").d().norm(), 0, kDrawingPixelTol);
  EXPECT_NEAR(std::abs(axis_line(side, "hip_rz").d().y()), 0.01 * side.scale, kDrawingPixelTol);
  // hip_rx turns about the femur's long axis, which lies in the x-y plane along -110°.
  const Eigen::Vector2d d = axis_line(top, "hip_rx").d();
  EXPECT_NEAR(d.norm(), 0.01 * top.scale, kDrawingPixelTol);
  // Parallel to the femur: the 2-D cross product of the drawn segment (world x, world y = -screen
  // y) with the femur direction vanishes.
  const double hip = -110 * M_PI / 180;
  EXPECT_NEAR(d.x() * std::sin(hip) - (-d.y()) * std::cos(hip), 0, kDrawingPixelTol)
      << "hip_rx along the femur";
}

TEST(LimbStickFigureSvg, WrongPostureSizeIsRefused) {
  const isowrench::Model model = Rat();
  EXPECT_THROW(isowrench::LimbStickFigureSvg(model, Eigen::VectorXd::Zero(2)), isowrench::Error);
  Eigen::VectorXd q = model.nominal_posture();
  q[0] = std::nan("");
  EXPECT_THROW(isowrench::LimbStickFigureSvg(model, q), isowrench::Error);
}

// The rat's limb with 38 muscles crowded between the same few places (as an imported OpenSim
// hindlimb has): every label would sit on the others if put where the first one goes.
isowrench::Model CrowdedRat(int muscles) {
  isowrench::LimbDescription d = Rat().description();
  d.muscles.clear();
  for (int i = 0; i < muscles; ++i) {
    isowrench::MuscleSpec m;
    m.name = "R_muscle_" + std::to_string(i);
    m.max_force = 1.0;
    const double s = 1e-4 * i;
    m.path.push_back({"ground", Eigen::Vector3d(0.012 + s, -0.010 + 0.5 * s, -0.004)});
    m.path.push_back({"tibia", Eigen::Vector3d(0.015 - 0.5 * s, -0.004 + s, -0.003)});
    d.muscles.push_back(m);
  }
  return isowrench::Model(d);
}

// A text element's box as the drawing documents it: n characters at f px are 0.62 n f wide,
// from 0.85 f above to 0.25 f below the baseline (start anchor).
struct TextBox {
  double x0, y0, x1, y1;
  std::string text;
};
TextBox BoxOf(const tinyxml2::XMLElement* e) {
  const std::string text = e->GetText() ? e->GetText() : "";
  size_t n = 0;
  for (unsigned char c : text) n += (c & 0xC0) != 0x80;
  const double f = Num(e, "font-size"), x = Num(e, "x"), y = Num(e, "y");
  return {x, y - 0.85 * f, x + 0.62 * f * static_cast<double>(n), y + 0.25 * f, text};
}

TEST(LimbStickFigureSvg, LabelsOfA38MuscleLimbDoNotOverlap) {
  const isowrench::Model model = CrowdedRat(38);
  tinyxml2::XMLDocument doc;
  const std::string svg = isowrench::LimbStickFigureSvg(model, model.nominal_posture());
  ASSERT_EQ(doc.Parse(svg.c_str()), tinyxml2::XML_SUCCESS) << doc.ErrorStr();
  for (const char* name : {"top", "side"}) {
    SCOPED_TRACE(name);
    const View v = ReadView(doc.RootElement(), name);
    std::vector<TextBox> boxes;
    int muscle_labels = 0, left_out = 0;
    for (const auto* t : ByTag(v.g, "text")) {
      if (HasClass(t, "view-title") || HasClass(t, "scale-label")) continue;
      if (HasClass(t, "label-note")) {
        // "N labels left out ...", the names in data-left-out (separated by ';').
        left_out = std::atoi(t->GetText());
        const std::string names = t->Attribute("data-left-out");
        EXPECT_EQ(static_cast<int>(std::count(names.begin(), names.end(), ';')) + 1, left_out);
        continue;
      }
      muscle_labels += HasClass(t, "muscle-label");
      boxes.push_back(BoxOf(t));
    }
    for (size_t i = 0; i < boxes.size(); ++i) {
      for (size_t j = i + 1; j < boxes.size(); ++j) {
        const TextBox &a = boxes[i], &b = boxes[j];
        const bool overlap = a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
        EXPECT_FALSE(overlap) << "'" << a.text << "' and '" << b.text << "'";
      }
    }
    // Every muscle is labelled or counted as left out; crowded as they are, each gets a label
    // (stacked beside the paths with leader lines where needed).
    EXPECT_EQ(muscle_labels + left_out, 38);
    EXPECT_EQ(muscle_labels, 38);
  }
}

TEST(LimbStickFigureSvg, MuscleFilterDrawsOnlyTheNamedMuscles) {
  const isowrench::Model model = CrowdedRat(5);
  isowrench::LimbDrawingOptions options;
  options.muscles = {"R_muscle_3", "R_muscle_1"};
  tinyxml2::XMLDocument doc;
  const std::string svg = isowrench::LimbStickFigureSvg(model, model.nominal_posture(), options);
  ASSERT_EQ(doc.Parse(svg.c_str()), tinyxml2::XML_SUCCESS) << doc.ErrorStr();
  const View top = ReadView(doc.RootElement(), "top");
  std::vector<std::string> drawn;
  for (const auto* m : ByClass(top.g, "muscle")) drawn.push_back(m->Attribute("data-muscle"));
  EXPECT_EQ(drawn, (std::vector<std::string>{"R_muscle_1", "R_muscle_3"}));  // model order
  options.muscles = {"R_muscle_1", "nosuch"};
  EXPECT_THAT([&] { isowrench::LimbStickFigureSvg(model, model.nominal_posture(), options); },
              ThrowsMessage<isowrench::Error>(HasSubstr("nosuch")));
}

}  // namespace
}  // namespace isowrench_test
