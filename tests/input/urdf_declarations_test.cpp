// Issue 26, item 2: declarations the reader used to drop or silently override are errors naming
// both lines: the same isowrench: element twice (the last won), role="base" on a revolute joint,
// isowrench elements under another prefix bound to isowrench's namespace or under a prefix that
// is declared nowhere (dropped), and isowrench elements standing where the reader never looks.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "isowrench/error.hpp"
#include "isowrench/model.hpp"

namespace {

using isowrench::Error;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

std::string Shipped(const std::string& file) {
  std::ifstream in(std::string(ISOWRENCH_TEST_URDF_DIR) + "/" + file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `text` with the one occurrence of `from` replaced (the test fails if it is absent).
std::string Edit(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Line 47 of rat_hindlimb_5dof.urdf is the first <isowrench:posture>: inserting one line before
// it puts the new element at line 47.
std::string Rat5With(const std::string& element) {
  return Edit(Shipped("rat_hindlimb_5dof.urdf"), "  <isowrench:posture joint=\"hip_rz\"",
              element + "\n  <isowrench:posture joint=\"hip_rz\"");
}

void ExpectError(const std::string& xml, const std::vector<std::string>& parts) {
  std::vector<::testing::Matcher<const std::string&>> all;
  for (const std::string& p : parts) all.push_back(HasSubstr(p));
  EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "d.urdf"); },
              ThrowsMessage<Error>(::testing::AllOfArray(all)));
}

TEST(UrdfDeclarations, JointDeclaredTwiceNamesBothLines) {
  // The case: base_z twice with different stiffnesses; the last used to win.
  const std::string xml =
      Edit(Shipped("rat_hindlimb_5dof_base.urdf"),
           "  <isowrench:joint name=\"base_z\" role=\"base\" stiffness=\"1e5\"/>\n",
           "  <isowrench:joint name=\"base_z\" role=\"base\" stiffness=\"1e5\"/>\n"
           "  <isowrench:joint name=\"base_z\" role=\"base\" stiffness=\"2e5\"/>\n");
  ExpectError(xml, {"d.urdf:60: <isowrench:joint> 'base_z' is declared twice", "(first at line 59)",
                    "keep one"});
}

TEST(UrdfDeclarations, SecondTransducerNamesTheFirst) {
  ExpectError(Rat5With("<isowrench:transducer link=\"tibia\" xyz=\"0.04 0 0\"/>"),
              {"d.urdf:47: a second <isowrench:transducer>", "(first at line 37)"});
}

TEST(UrdfDeclarations, PostureOfOneCoordinateTwiceNamesBothLines) {
  ExpectError(Rat5With("<isowrench:posture joint=\"knee_rz\" value=\"1.8\"/>"),
              {"d.urdf:49: <isowrench:posture> 'knee_rz' is declared twice", "(first at line 47)"});
}

TEST(UrdfDeclarations, MuscleDeclaredTwiceNamesBothLines) {
  ExpectError(Rat5With("<isowrench:muscle name=\"GP\" max_force=\"1\">"
                       "<isowrench:point link=\"ground\"/><isowrench:point link=\"tibia\"/>"
                       "</isowrench:muscle>"),
              {"d.urdf:47: <isowrench:muscle> 'GP' is declared twice", "(first at line 41)"});
}

TEST(UrdfDeclarations, WrapObjectDeclaredTwiceNamesBothLines) {
  ExpectError(Rat5With("<isowrench:wrap name=\"knee_cyl\" link=\"femur\" shape=\"sphere\" "
                       "radius=\"0.003\"/>\n  <isowrench:wrap name=\"knee_cyl\" link=\"tibia\" "
                       "shape=\"sphere\" radius=\"0.002\"/>"),
              {"d.urdf:48: <isowrench:wrap> 'knee_cyl' is declared twice", "(first at line 47)"});
  // A path_wrap inside a standard element is read by nothing: an error naming where it belongs.
  ExpectError(Edit(Shipped("rat_hindlimb_5dof.urdf"), "<link name=\"tibia\"/>",
                   "<link name=\"tibia\"><isowrench:path_wrap object=\"knee_cyl\"/></link>"),
              {"d.urdf:13: <isowrench:path_wrap> stands inside <link> (line 13)",
               "directly inside <isowrench:muscle>"});
}

TEST(UrdfDeclarations, BaseRoleOnARevoluteJointNamesBothLines) {
  ExpectError(Rat5With("<isowrench:joint name=\"knee_rx\" role=\"base\" stiffness=\"1e5\"/>"),
              {"d.urdf:47: joint 'knee_rx' (line 31) is revolute but has role=\"base\"",
               "prismatic", "role=\"extra\""});
  // On a prismatic base joint it is what the shipped base model says.
  EXPECT_NO_THROW(isowrench::ReadUrdfString(Shipped("rat_hindlimb_5dof_base.urdf"), "b.urdf"));
}

TEST(UrdfDeclarations, BaseRoleOnARevoluteFreeCoordinateIsAnError) {
  ExpectError(Rat5With("<isowrench:coordinate name=\"q_free\" type=\"revolute\"/>\n"
                       "  <isowrench:joint name=\"q_free\" role=\"base\"/>"),
              {"d.urdf:48: coordinate 'q_free' (line 47) is revolute but has role=\"base\""});
}

TEST(UrdfDeclarations, OtherPrefixBoundToIsowrenchNamespaceNamesBothLines) {
  // The muscle used to be dropped without a word: the limb had one muscle, not two.
  std::string xml =
      Edit(Shipped("rat_hindlimb_5dof.urdf"), "xmlns:isowrench=\"urn:isowrench:urdf:1\"",
           "xmlns:isowrench=\"urn:isowrench:urdf:1\"\n"
           "       xmlns:iw=\"urn:isowrench:urdf:1\"");
  xml = Edit(xml, "  <isowrench:posture joint=\"hip_rz\"",
             "  <iw:muscle name=\"BF\" max_force=\"1\"><iw:point link=\"ground\"/>"
             "<iw:point link=\"tibia\"/></iw:muscle>\n  <isowrench:posture joint=\"hip_rz\"");
  ExpectError(xml, {"d.urdf:48: <iw:muscle> is in isowrench's namespace through the prefix 'iw'",
                    "xmlns:iw=\"urn:isowrench:urdf:1\" at line 7", "write <isowrench:muscle>"});
}

TEST(UrdfDeclarations, DefaultNamespaceBoundToIsowrenchIsAnError) {
  ExpectError(Rat5With("<muscle xmlns=\"urn:isowrench:urdf:1\" name=\"BF\" max_force=\"1\"/>"),
              {"d.urdf:47: <muscle> is in isowrench's namespace through the default namespace",
               "at line 47", "write <isowrench:muscle>"});
}

TEST(UrdfDeclarations, UndeclaredPrefixIsAnError) {
  ExpectError(Rat5With("<iw:muscle name=\"BF\" max_force=\"1\"/>"),
              {"d.urdf:47: <iw:muscle>: the namespace prefix 'iw' is declared nowhere",
               "isowrench's elements are written <isowrench:muscle>"});
  ExpectError(Rat5With("<xacro:property name=\"l\" value=\"1\"/>"),
              {"d.urdf:47: <xacro:property>: the namespace prefix 'xacro' is declared nowhere"});
}

TEST(UrdfDeclarations, ElementsOfOtherDeclaredNamespacesAreLeftAlone) {
  std::string xml =
      Edit(Shipped("rat_hindlimb_5dof.urdf"), "xmlns:isowrench=\"urn:isowrench:urdf:1\"",
           "xmlns:isowrench=\"urn:isowrench:urdf:1\" "
           "xmlns:xacro=\"http://www.ros.org/wiki/xacro\"");
  xml = Edit(xml, "  <isowrench:posture joint=\"hip_rz\"",
             "  <xacro:property name=\"l\" value=\"1\"/>\n  <gazebo reference=\"tibia\"/>\n"
             "  <isowrench:posture joint=\"hip_rz\"");
  EXPECT_EQ(isowrench::ReadUrdfString(xml, "ok.urdf").muscles.size(), 1u);
}

TEST(UrdfDeclarations, MisplacedElementNamesItsParent) {
  // A muscle inside a link used to be ignored.
  std::string xml = Edit(Shipped("rat_hindlimb_5dof.urdf"), "<link name=\"tibia\"/>",
                         "<link name=\"tibia\">\n    <isowrench:muscle name=\"BF\" "
                         "max_force=\"1\"/>\n  </link>");
  ExpectError(xml, {"<isowrench:muscle> stands inside <link> (line", "directly inside <robot>"});
  xml = Edit(Shipped("rat_hindlimb_5dof.urdf"), "<axis xyz=\"1 0 0\"/>\n  </joint>\n\n",
             "<axis xyz=\"1 0 0\"/>\n    <isowrench:point link=\"tibia\"/>\n  </joint>\n\n");
  ExpectError(xml, {"d.urdf:34: <isowrench:point> stands inside <joint> (line 31)",
                    "directly inside <isowrench:muscle>"});
}

}  // namespace
