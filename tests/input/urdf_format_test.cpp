// Issue 26, item 0: no text of a URDF reaches a printf format. urdfdom logs through
// console_bridge, which formats with vsnprintf before any handler sees the message, and some of
// urdfdom's messages hold the file's text as the format ("Unable to parse component [%s%s...]"):
// an origin xyz="%s%s%s 0 0" crashed every command, "%n" aborted it. Every attribute urdfdom reads
// is now checked by isowrench first (file:line, element, attribute, value), and urdfdom runs
// with console_bridge silenced.

#include <console_bridge/console.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/model.hpp"
#include "model/urdf_standard.hpp"

namespace {

using isowrench::Error;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// A limb holding every element and attribute urdfdom reads, each value a token @path@attribute@
// replaced by a valid value, or by a bad one in turn.
const char* kEveryElement = R"(<robot name="every_element">
  <material name="grey"><color rgba="@material/color@rgba@"/></material>
  <link name="ground"/>
  <link name="upper">
    <inertial>
      <origin xyz="@link/inertial/origin@xyz@" rpy="@link/inertial/origin@rpy@"/>
      <mass value="@link/inertial/mass@value@"/>
      <inertia ixx="@link/inertial/inertia@ixx@" ixy="@link/inertial/inertia@ixy@"
               ixz="@link/inertial/inertia@ixz@" iyy="@link/inertial/inertia@iyy@"
               iyz="@link/inertial/inertia@iyz@" izz="@link/inertial/inertia@izz@"/>
    </inertial>
    <visual>
      <origin xyz="@link/visual/origin@xyz@" rpy="@link/visual/origin@rpy@"/>
      <geometry><box size="@link/visual/geometry/box@size@"/></geometry>
      <material name="bone"><color rgba="@link/visual/material/color@rgba@"/></material>
    </visual>
    <visual><geometry><sphere radius="@link/visual/geometry/sphere@radius@"/></geometry></visual>
    <visual><geometry><cylinder length="@link/visual/geometry/cylinder@length@"
                                radius="@link/visual/geometry/cylinder@radius@"/></geometry></visual>
    <visual><geometry><mesh filename="femur.stl" scale="@link/visual/geometry/mesh@scale@"/>
    </geometry></visual>
    <collision>
      <origin xyz="@link/collision/origin@xyz@" rpy="@link/collision/origin@rpy@"/>
      <geometry><box size="@link/collision/geometry/box@size@"/></geometry>
    </collision>
    <collision><geometry><sphere radius="@link/collision/geometry/sphere@radius@"/></geometry>
    </collision>
    <collision><geometry><cylinder length="@link/collision/geometry/cylinder@length@"
                              radius="@link/collision/geometry/cylinder@radius@"/></geometry>
    </collision>
    <collision><geometry><mesh filename="femur.stl" scale="@link/collision/geometry/mesh@scale@"/>
    </geometry></collision>
  </link>
  <link name="lower"/>
  <link name="hand"/>
  <joint name="shoulder" type="revolute">
    <parent link="ground"/> <child link="upper"/>
    <origin xyz="@joint/origin@xyz@" rpy="@joint/origin@rpy@"/>
    <axis xyz="@joint/axis@xyz@"/>
    <limit lower="@joint/limit@lower@" upper="@joint/limit@upper@"
           effort="@joint/limit@effort@" velocity="@joint/limit@velocity@"/>
    <safety_controller soft_lower_limit="@joint/safety_controller@soft_lower_limit@"
                       soft_upper_limit="@joint/safety_controller@soft_upper_limit@"
                       k_position="@joint/safety_controller@k_position@"
                       k_velocity="@joint/safety_controller@k_velocity@"/>
    <calibration rising="@joint/calibration@rising@" falling="@joint/calibration@falling@"/>
    <dynamics damping="@joint/dynamics@damping@" friction="@joint/dynamics@friction@"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/> <child link="lower"/>
    <origin xyz="0.1 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="wrist" type="revolute">
    <parent link="lower"/> <child link="hand"/>
    <origin xyz="0.1 0 0"/> <axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/>
    <mimic joint="elbow" multiplier="@joint/mimic@multiplier@" offset="@joint/mimic@offset@"/>
  </joint>
  <isowrench:transducer link="hand" xyz="0.05 0 0"/>
</robot>
)";

/// A valid value for a token's attribute.
std::string ValidValue(const isowrench::urdf_standard::StandardAttribute& a) {
  const std::string attribute = a.attribute;
  if (a.numbers == 4) return "0.5 0.5 0.5 1";
  if (attribute == "xyz" && std::string(a.element) == "joint/axis") return "0 0 1";
  if (attribute == "xyz") return "0 0 0";
  if (a.numbers == 3) return "0.1 0.1 0.1";
  if (attribute == "lower") return "-2";
  if (attribute == "upper") return "2";
  if (attribute == "multiplier") return "1";
  if (attribute == "offset") return "0";
  return "0.01";
}

std::string Token(const isowrench::urdf_standard::StandardAttribute& a) {
  return std::string("@") + a.element + "@" + a.attribute + "@";
}

/// kEveryElement with every token valid, except `bad_token` (if any) set to `bad`.
std::string Fill(const std::string& bad_token, const std::string& bad, int* bad_line) {
  std::string xml = kEveryElement;
  for (const auto& a : isowrench::urdf_standard::StandardAttributes()) {
    if (a.numbers == 0) continue;
    const std::string token = Token(a);
    const size_t at = xml.find(token);
    if (at == std::string::npos) continue;
    if (token == bad_token && bad_line) {  // the line of the element's '<' (tinyxml2's line)
      const size_t open = xml.rfind('<', at);
      *bad_line = 1 + static_cast<int>(std::count(xml.begin(), xml.begin() + open, '\n'));
    }
    xml.replace(at, token.size(), token == bad_token ? bad : ValidValue(a));
  }
  return xml;
}

TEST(UrdfNumbers, TheTemplateIsValidAndHoldsEveryNumericAttributeUrdfdomReads) {
  for (const auto& a : isowrench::urdf_standard::StandardAttributes()) {
    if (a.numbers > 0) {
      EXPECT_NE(std::string(kEveryElement).find(Token(a)), std::string::npos) << Token(a);
    }
  }
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Fill("", "", nullptr), "all.urdf");
  EXPECT_EQ(d.joints.size(), 3u);
}

// Every numeric attribute urdfdom reads, given format directives: an error naming the file and
// line, the element, the attribute and the value, and no crash (a crash or abort fails the test
// binary; under ASan the sanitizer's "unexpected format specifier" report would show it too).
TEST(UrdfNumbers, FormatDirectivesInEveryNumericAttributeAreAnErrorNamingIt) {
  int checked = 0;
  for (const auto& a : isowrench::urdf_standard::StandardAttributes()) {
    if (a.numbers == 0) continue;
    const std::string leaf = std::string(a.element).substr(std::string(a.element).rfind('/') + 1);
    const std::vector<std::string> bad_values =
        a.numbers == 1 ? std::vector<std::string>{"%s%s%s%s%s%s%n", "%99999d"}
        : a.numbers == 3
            ? std::vector<std::string>{"%s%s%s%s%s%s%s%s%s%s%s%s 0 0", "0 %n 0", "0 0 %99999d"}
            : std::vector<std::string>{"%s%s%s 0 0 1", "0 0 0 %n"};
    for (const std::string& bad : bad_values) {
      int line = 0;
      const std::string xml = Fill(Token(a), bad, &line);
      ASSERT_GT(line, 0) << Token(a);
      EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "fmt.urdf"); },
                  ThrowsMessage<Error>(AllOf(
                      HasSubstr("fmt.urdf:" + std::to_string(line) + ":"),
                      HasSubstr("<" + leaf + "> attribute " + a.attribute + " = '" + bad + "'"),
                      HasSubstr("is not a finite number"))))
          << Token(a) << " = " << bad;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 2 * 27 + 3 * 13 + 2 * 2);  // 27 scalars, 13 vectors, 2 colours
}

TEST(UrdfNumbers, ValuesUrdfdomRefusesAreRefusedFirst) {
  struct Case {
    std::string token, value, says;
  };
  for (const Case& c : std::vector<Case>{
           {"@joint/origin@xyz@", "0 0", "holds 2 numbers; it must hold 3"},
           {"@joint/origin@xyz@", "0 0 0 0", "holds 4 numbers"},
           {"@joint/origin@rpy@", "0,0,0", "'0,0,0' is not a finite number"},
           {"@joint/axis@xyz@", "0\t0 1", "spaces only"},
           {"@joint/limit@lower@", "nan", "is not a finite number"},
           {"@joint/limit@upper@", "1e999", "is not a finite number"},
           {"@joint/limit@effort@", "1 ", "is not a finite number"},
           {"@joint/mimic@multiplier@", "0x10", "is not a finite number"},
           {"@link/inertial/mass@value@", "1,5", "is not a finite number"},
           {"@material/color@rgba@", "1 0 0 2", "component 2 is outside [0, 1]"},
       }) {
    int line = 0;
    const std::string xml = Fill(c.token, c.value, &line);
    EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "v.urdf"); },
                ThrowsMessage<Error>(
                    AllOf(HasSubstr("v.urdf:" + std::to_string(line) + ":"), HasSubstr(c.says))))
        << c.token << " = " << c.value;
  }
  // What urdfdom reads as a number is read (blanks between components, a leading sign, an
  // exponent, a leading blank before a scalar).
  for (const auto& [token, value] :
       std::map<std::string, std::string>{{"@joint/origin@xyz@", "  +1e-2   0 -0.0 "},
                                          {"@joint/limit@lower@", " -2"},
                                          {"@joint/limit@upper@", "2."}}) {
    EXPECT_NO_THROW(isowrench::ReadUrdfString(Fill(token, value, nullptr), "ok.urdf"))
        << token << " = " << value;
  }
}

TEST(UrdfNumbers, ElementsAndAttributesUrdfdomRequiresAreNamed) {
  const std::string xml = Fill("", "", nullptr);
  auto without = [&](const std::string& from, const std::string& to) {
    std::string out = xml;
    const size_t at = out.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) out.replace(at, from.size(), to);
    return out;
  };
  struct Case {
    std::string from, to, says;
  };
  for (const Case& c : std::vector<Case>{
           {R"(effort="1" velocity="1"/>
  </joint>
  <joint name="wrist")",
            R"(velocity="1"/>
  </joint>
  <joint name="wrist")",
            "joint 'elbow': <limit> needs the attribute 'effort'"},
           {R"(<limit lower="-2" upper="2" effort="1" velocity="1"/>
    <mimic)",
            "<mimic", "joint 'wrist': <joint> needs a <limit> element (a revolute joint"},
           {"<mass value=\"0.01\"/>", "", "link 'upper': <inertial> needs a <mass> element"},
           {"<sphere radius=\"0.01\"/></geometry></visual>", "<ball/></geometry></visual>",
            "link 'upper': <geometry> needs one of <sphere>, <box>, <cylinder>, <mesh>, not "
            "<ball>"},
           {"<mimic joint=\"elbow\"", "<mimic",
            "joint 'wrist': <mimic> needs the attribute 'joint'"},
           {"<robot name=\"every_element\">", "<robot>", "<robot> needs the attribute 'name'"},
           {"<robot name=\"every_element\">", "<robot name=\"r\" version=\"2.0\">",
            "only URDF version 1.0"},
           {"<link name=\"lower\"/>", "<link name=\"lower\"/><link name=\"lower\"/>",
            "link 'lower' is defined twice"},
           {"<child link=\"hand\"/>", "<child link=\"hnd\"/>",
            "<child link='hnd'> names no <link> of the file (did you mean 'hand'?)"},
           {"<link name=\"hand\"/>", "<link name=\"hand\"/><link name=\"stray\"/>",
            "links 'ground' (line 3) and 'stray' are both roots"},
       }) {
    EXPECT_THAT([&] { isowrench::ReadUrdfString(without(c.from, c.to), "r.urdf"); },
                ThrowsMessage<Error>(AllOf(HasSubstr("r.urdf:"), HasSubstr(c.says))))
        << c.says;
  }
}

// The issue's file: the rat limb with format directives in a joint origin. Each used to crash
// `isowrench wrench` (exit 139) or abort it ("%n in writable segment detected").
TEST(UrdfNumbers, IssueExampleInTheRatLimbIsAnErrorNotACrash) {
  std::ifstream in(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
  std::stringstream text;
  text << in.rdbuf();
  const std::string good = R"(<origin xyz="0.031 0 0")";
  for (const std::string bad : {"%s%s%s%s%s%s%s%s%s%s%s%s 0 0", "%n%n%n 0 0"}) {
    std::string xml = text.str();
    xml.replace(xml.find(good), good.size(), "<origin xyz=\"" + bad + "\"");
    EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "rat.urdf"); },
                ThrowsMessage<Error>(AllOf(HasSubstr("rat.urdf:29: joint 'knee_rz': <origin> "
                                                     "attribute xyz = '" +
                                                     bad + "'"),
                                           HasSubstr("is not a finite number"))));
  }
}

/// Counts what console_bridge hands to its output handler.
class CountingHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel, const char*, int) override {
    ++count;
    last = text;
  }
  int count = 0;
  std::string last;
};

// urdfdom itself runs silenced: console_bridge::log() formats nothing (it would vsnprintf the
// file's text as the format before any handler ran), and the caller's log level comes back.
TEST(UrdfNumbers, UrdfdomRunsWithConsoleBridgeSilencedAndTheLevelRestored) {
  const std::string bad = R"(<robot name="r"><link name="a"/><link name="b"/>
    <joint name="j" type="fixed"><parent link="a"/><child link="b"/>
      <origin xyz="x%n%n%n 0 0"/></joint></robot>)";
  const std::string unformatted = R"(<robot name="r"><link name="a"/><link name="b"/>
    <joint name="j" type="fixed"><parent link="a"/><child link="b"/>
      <origin xyz="x 0 0"/></joint></robot>)";
  CountingHandler handler;
  console_bridge::useOutputHandler(&handler);
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_DEBUG);
  // The handler sees urdfdom's messages when urdfdom is called directly (so the check below
  // can fail): the component's text is in the message.
  EXPECT_EQ(urdf::parseURDF(unformatted), nullptr);
  EXPECT_GT(handler.count, 0);
  handler.count = 0;
  EXPECT_EQ(isowrench::urdf_standard::ParseQuietly(unformatted), nullptr);
  EXPECT_EQ(isowrench::urdf_standard::ParseQuietly(bad), nullptr);
  EXPECT_EQ(handler.count, 0) << handler.last;
  EXPECT_EQ(console_bridge::getLogLevel(), console_bridge::CONSOLE_BRIDGE_LOG_DEBUG);
  console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_WARN);
  console_bridge::restorePreviousOutputHandler();
}

}  // namespace
