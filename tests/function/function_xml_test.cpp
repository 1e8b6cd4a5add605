// The function elements of the URDF extension: parse, write, round trip, errors with file:line.

#include "model/function_xml.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "isowrench/error.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// Parse the first child element of <root> in `xml` (the root adds line 1).
Function ParseFirst(const std::string& xml) {
  tinyxml2::XMLDocument doc;
  const std::string text = "<root xmlns:isowrench=\"urn:isowrench:urdf:1\">\n" + xml + "</root>";
  EXPECT_EQ(doc.Parse(text.c_str()), tinyxml2::XML_SUCCESS);
  return ParseFunctionXml(*doc.RootElement()->FirstChildElement(), "knee.urdf");
}

TEST(FunctionXml, ParsesEveryKind) {
  EXPECT_EQ(ParseFirst("<isowrench:constant value=\"0.001\"/>").Value(5), 0.001);
  Function l = ParseFirst("<isowrench:linear slope=\"2\" intercept=\"-1\"/>");
  EXPECT_EQ(l.Value(3), 5.0);
  // Parabola y = 2x - x^2 through three SimmSpline knots.
  Function s = ParseFirst("<isowrench:simm_spline x=\"0 1 2\" y=\"0 1 0\"/>");
  EXPECT_EQ(s.kind(), FunctionKind::kSimmSpline);
  EXPECT_NEAR(s.Value(0.5), 0.75, 1e-12);
  Function n = ParseFirst("<isowrench:natural_cubic_spline x=\"0 1 2\" y=\"0 1 0\"/>");
  EXPECT_NEAR(n.Value(0.5), 0.6875, 1e-12);  // 1.5 x - 0.5 x^3
  Function p = ParseFirst("<isowrench:piecewise_linear x=\"0\n 1\" y=\"1 3\"/>");
  EXPECT_EQ(p.Value(0.5), 2.0);
  Function q = ParseFirst("<isowrench:polynomial coefficients=\"1 0 -1\"/>");
  EXPECT_EQ(q.Value(3), 8.0);
  Function m = ParseFirst(
      "<isowrench:multiplier scale=\"2\">\n  <isowrench:linear slope=\"1\" intercept=\"1\"/>\n"
      "</isowrench:multiplier>");
  EXPECT_EQ(m.Value(1), 4.0);
  EXPECT_TRUE(m.is_linear());
}

TEST(FunctionXml, WriteThenParseEvaluatesBitForBit) {
  const std::vector<Function> functions = {
      Function::Constant(0.1),
      Function::Linear(1.0 / 3.0, -0.2),
      Function::SimmSpline({-2.0944, -1.3, -0.7, 0.1745329}, {0.0011, 0.0031, -0.0007, 0.002}),
      Function::NaturalCubicSpline({0, 0.3, 1}, {1.0 / 7.0, 2, 3}),
      Function::PiecewiseLinear({0, 1}, {0.1, 0.7}),
      Function::Polynomial({M_PI, 0, 1e-300}),
      Function::Multiplier(Function::Multiplier(Function::SimmSpline({0, 1}, {0, 1}), 0.5), -3)};
  for (const Function& f : functions) {
    const std::string xml = FunctionXmlText(f, "  ");
    Function g = ParseFirst(xml);
    EXPECT_EQ(g.kind(), f.kind()) << xml;
    for (double x : {-3.0, -1.0, 0.05, 0.5, 2.0}) {
      EXPECT_EQ(g.Value(x), f.Value(x)) << xml;
      EXPECT_EQ(g.Derivative(x), f.Derivative(x)) << xml;
    }
  }
  EXPECT_EQ(FunctionXmlText(Function::Linear(0.5, 0), ""),
            "<isowrench:linear slope=\"0.5\" intercept=\"0\"/>\n");
}

TEST(FunctionXml, ErrorsNameFileLineElementAndRule) {
  EXPECT_THAT([] { ParseFirst("<isowrench:simm_spline x=\"0 2 1\" y=\"0 1 2\"/>"); },
              ThrowsMessage<Error>(HasSubstr(
                  "knee.urdf:2: <isowrench:simm_spline>: SimmSpline knots must be strictly "
                  "increasing")));
  EXPECT_THAT([] { ParseFirst("<isowrench:simm_spline x=\"0 1 nan\" y=\"0 1 2\"/>"); },
              ThrowsMessage<Error>(HasSubstr("knee.urdf:2: <isowrench:simm_spline>: SimmSpline "
                                             "knot x[2] = nan is not finite")));
  EXPECT_THAT([] { ParseFirst("<isowrench:linear slope=\"1\"/>"); },
              ThrowsMessage<Error>(HasSubstr("knee.urdf:2: <isowrench:linear>: needs the "
                                             "attribute 'intercept'")));
  EXPECT_THAT([] { ParseFirst("<isowrench:constant value=\"0.1mm\"/>"); },
              ThrowsMessage<Error>(HasSubstr("'0.1mm', which is not a number")));
  EXPECT_THAT([] { ParseFirst("<isowrench:gcv_spline x=\"0 1\" y=\"0 1\"/>"); },
              ThrowsMessage<Error>(HasSubstr("knee.urdf:2: <isowrench:gcv_spline>: unknown "
                                             "function element; expected one of")));
  EXPECT_THAT(
      [] {
        ParseFirst(
            "<isowrench:multiplier scale=\"2\">\n<isowrench:constant value=\"1\"/>\n"
            "<isowrench:constant value=\"2\"/>\n</isowrench:multiplier>");
      },
      ThrowsMessage<Error>(HasSubstr("knee.urdf:4: <isowrench:multiplier> holds a second "
                                     "function element <isowrench:constant> (line 3")));
  EXPECT_THAT([] { ParseFirst("<isowrench:multiplier scale=\"2\"/>"); },
              ThrowsMessage<Error>(HasSubstr("knee.urdf:2: <isowrench:multiplier> needs one "
                                             "function element")));
  EXPECT_THAT(
      [] {
        ParseFirst(
            "<isowrench:multiplier scale=\"2\">\n<isowrench:simm_spline x=\"1 0\" "
            "y=\"0 1\"/>\n</isowrench:multiplier>");
      },
      ThrowsMessage<Error>(HasSubstr("knee.urdf:3: <isowrench:simm_spline>: SimmSpline knots")));
}

}  // namespace
}  // namespace isowrench
