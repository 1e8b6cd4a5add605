// URDF input: joint loops and two-parent links are errors naming the joints (they used to hang
// urdfdom), unknown attributes on isowrench: elements are errors with a suggestion, stiffness
// beyond kMaxStiffness is an error naming its origin, implausible dimensions warn.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "isowrench/input_checks.hpp"
#include "isowrench/isowrench.hpp"

namespace {

using isowrench::Error;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string Rat5Text() {
  return ReadText(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
}

/// Replace the one occurrence of `from` (the test fails if it is absent).
std::string Replace(std::string text, const std::string& from, const std::string& to) {
  size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// A four-link chain whose last two joints form a loop that does not reach the root: the
// fuzzer's find (issue 16, defect 10).
const char* kLoop = R"(<robot name="loop">
  <link name="link1"/> <link name="link2"/> <link name="link3"/> <link name="link4"/>
  <joint name="j1" type="revolute"><parent link="link1"/><child link="link2"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j3" type="revolute"><parent link="link4"/><child link="link3"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j4" type="revolute"><parent link="link3"/><child link="link4"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <isowrench:transducer link="link4" xyz="0.01 0 0"/>
</robot>)";

TEST(UrdfTree, JointLoopIsAnErrorNamingTheJoints) {
  EXPECT_THAT([] { isowrench::ReadUrdfString(kLoop, "loop.urdf"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("loop.urdf:5"), HasSubstr("'j3'"),
                                         HasSubstr("'j4'"), HasSubstr("loop"))));
}

TEST(UrdfTree, LinkWithTwoParentsIsAnError) {
  std::string xml = Replace(Rat5Text(), R"(<parent link="knee_z_link"/> <child link="tibia"/>)",
                            R"(<parent link="knee_z_link"/> <child link="femur"/>)");
  EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "two.urdf"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("two parents"), HasSubstr("'hip_rx'"),
                                         HasSubstr("'knee_rx'"), HasSubstr("'femur'"))));
}

TEST(UrdfTree, JointWhoseParentIsItsChildIsAnError) {
  std::string xml = Replace(Rat5Text(), R"(<parent link="femur"/> <child link="knee_z_link"/>)",
                            R"(<parent link="femur"/> <child link="femur"/>)");
  EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "self.urdf"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("self.urdf:27"), HasSubstr("'knee_rz'"),
                                         HasSubstr("both parent and child"))));
}

// Found by fuzz/osim_import_fuzzer.cpp (seed fuzz/corpus/osim/raw_ampersand_name.osim): an
// OpenSim coordinate named "p&elvis_rz" (a raw '&', which tinyxml2 reads leniently) was written
// verbatim into a URDF attribute that did not read back. The writer refuses such names.
TEST(UrdfWriter, NameThatXmlCannotHoldIsRefusedNamingIt) {
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Rat5Text(), "rat.urdf");
  ASSERT_FALSE(d.muscles.empty());
  EXPECT_NO_THROW(isowrench::WriteUrdfString(d));
  d.muscles.front().name = "G&P";
  EXPECT_THAT([&] { isowrench::WriteUrdfString(d); },
              ThrowsMessage<Error>(AllOf(HasSubstr("muscle name 'G&P'"), HasSubstr("rename it"))));
  d.muscles.front().name = "G<P";
  EXPECT_THROW(isowrench::WriteUrdfString(d), Error);
}

// Found by fuzz/osim_import_fuzzer.cpp (seed fuzz/corpus/osim/latin1_model_name.osim): an
// OpenSim model whose name held a byte that is not UTF-8 (0xED, from a file saved as Latin-1)
// was written into a URDF that tinyxml2 then refused ("Error reading Attributes"). The writer
// refuses names that are not well-formed UTF-8 (RFC 3629) and shows the bytes; UTF-8 names,
// multi-byte ones included, are written and read back.
TEST(UrdfWriter, NameThatIsNotUtf8IsRefusedShowingTheBytes) {
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Rat5Text(), "rat.urdf");
  for (const std::string good : {"f\xC3\xA9mur", "\xE8\x85\xBF", "leg\xF0\x9F\xA6\xB5"}) {
    d.name = good;  // é, a CJK character, an emoji (2, 3 and 4 bytes)
    const std::string urdf = isowrench::WriteUrdfString(d);
    EXPECT_EQ(isowrench::ReadUrdfString(urdf, "back.urdf").name, good);
  }
  d.name =
      "fixture_hindli\xED"
      "b";
  EXPECT_THAT([&] { isowrench::WriteUrdfString(d); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("model name 'fixture_hindli\\xEDb'"), HasSubstr("not UTF-8"))));
  d.name = "rat";
  // Overlong '/', a UTF-16 surrogate, a truncated 3-byte sequence, beyond U+10FFFF, a lone
  // continuation byte.
  for (const std::string bad : {"a\xC0\xAF", "a\xED\xA0\x80", "a\xE2\x82", "a\xF4\x90\x80\x80",
                                "a\x80"
                                "b"}) {
    d.muscles.front().name = bad;
    EXPECT_THAT([&] { isowrench::WriteUrdfString(d); },
                ThrowsMessage<Error>(AllOf(HasSubstr("muscle name"), HasSubstr("not UTF-8"))));
  }
}

// The source path goes into the file's first comment only when a comment can hold it.
TEST(UrdfWriter, SourcePathThatACommentCannotHoldIsLeftOut) {
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Rat5Text(), "rat.urdf");
  d.source = "/data/rat--left.osim";
  std::string urdf = isowrench::WriteUrdfString(d);
  EXPECT_THAT(urdf, Not(HasSubstr("rat--left")));
  EXPECT_NO_THROW(isowrench::ReadUrdfString(urdf, "back.urdf"));
  d.source = "/data/rat_left.osim";
  urdf = isowrench::WriteUrdfString(d);
  EXPECT_THAT(urdf, HasSubstr("from /data/rat_left.osim"));
}

TEST(UrdfAttributes, MisspeltTransducerStiffnessSuggestsTheName) {
  std::string xml = Replace(Rat5Text(), R"(stiffness="1e7 1e7 1e7 1e7 1e7 1e7")",
                            R"(stifness="1e3 1e3 1e3 1 1 1")");
  EXPECT_THAT(
      [&] { isowrench::ReadUrdfString(xml, "t.urdf"); },
      ThrowsMessage<Error>(AllOf(HasSubstr("t.urdf:37"), HasSubstr("<isowrench:transducer>"),
                                 HasSubstr("'stifness'"), HasSubstr("did you mean 'stiffness'?"))));
}

TEST(UrdfAttributes, MisspeltJointStiffnessSuggestsTheName) {
  std::string xml = Replace(
      Rat5Text(), "<isowrench:posture joint=\"hip_rz\"",
      "<isowrench:joint name=\"knee_rx\" stiffnes=\"1\"/>\n  <isowrench:posture joint=\"hip_rz\"");
  EXPECT_THAT(
      [&] { isowrench::ReadUrdfString(xml, "j.urdf"); },
      ThrowsMessage<Error>(AllOf(HasSubstr("j.urdf:47"), HasSubstr("<isowrench:joint>"),
                                 HasSubstr("'stiffnes'"), HasSubstr("did you mean 'stiffness'?"))));
}

TEST(UrdfAttributes, UnknownAttributeOnNestedPointIsNamed) {
  std::string xml = Replace(Rat5Text(), R"(<isowrench:point link="tibia" xyz=)",
                            R"(<isowrench:point lnk="tibia" xyz=)");
  EXPECT_THAT([&] { isowrench::ReadUrdfString(xml, "p.urdf"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("<isowrench:point>"), HasSubstr("'lnk'"),
                                         HasSubstr("did you mean 'link'?"))));
}

TEST(UrdfAttributes, UnknownPostureJointSuggestsTheClosest) {
  std::string xml = Replace(Rat5Text(), R"(<isowrench:posture joint="knee_rz")",
                            R"(<isowrench:posture joint="knee_z")");
  EXPECT_THAT(
      [&] { isowrench::ReadUrdfString(xml, "q.urdf"); },
      ThrowsMessage<Error>(AllOf(HasSubstr("'knee_z'"), HasSubstr("did you mean 'knee_rz'?"))));
}

TEST(UrdfAttributes, ContractAttributesAreAccepted) {
  // Names other readers rely on (coordinates, couplings, functions, moving points, locked=)
  // must never be rejected by the attribute check itself.
  std::string xml = Replace(Rat5Text(), "<isowrench:posture joint=\"hip_rz\"",
                            "<isowrench:joint name=\"knee_rx\" role=\"extra\" stiffness=\"1\"/>\n"
                            "  <isowrench:posture joint=\"hip_rz\"");
  EXPECT_NO_THROW(isowrench::ReadUrdfString(xml, "ok.urdf"));
}

TEST(Suggestions, ClosestNameByEditDistance) {
  EXPECT_EQ(isowrench::ClosestName("stifness", {"name", "role", "stiffness"}), "stiffness");
  EXPECT_EQ(isowrench::ClosestName("STIFFNESS", {"name", "stiffness"}), "stiffness");
  EXPECT_EQ(isowrench::ClosestName("colour", {"name", "stiffness"}), "");
}

// ---- defect 3: stiffness range -----------------------------------------------------------

TEST(StiffnessRange, HugeUrdfJointStiffnessIsAnErrorNamingTheElement) {
  std::string xml = Replace(Rat5Text(), "<isowrench:posture joint=\"hip_rz\"",
                            "<isowrench:joint name=\"knee_rx\" stiffness=\"1e308\"/>\n  "
                            "<isowrench:posture joint=\"hip_rz\"");
  EXPECT_THAT(
      [&] { isowrench::ReadUrdfString(xml, "k.urdf"); },
      ThrowsMessage<Error>(AllOf(HasSubstr("k.urdf:47"), HasSubstr("knee_rx"), HasSubstr("1e+308"),
                                 HasSubstr("exceeds the physical maximum 1e+15"))));
}

TEST(StiffnessRange, HugeTransducerStiffnessIsAnErrorNamingTheDof) {
  std::string xml = Replace(Rat5Text(), R"(stiffness="1e7 1e7 1e7 1e7 1e7 1e7")",
                            R"(stiffness="1e7 1e7 1e7 1e7 1e300 1e7")");
  EXPECT_THAT(
      [&] { isowrench::ReadUrdfString(xml, "t.urdf"); },
      ThrowsMessage<Error>(AllOf(HasSubstr("t.urdf:37"), HasSubstr("ry"), HasSubstr("1e+300"))));
}

TEST(StiffnessRange, ApiEditsNameTheFunction) {
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Rat5Text(), "rat5");
  EXPECT_THAT([&] { isowrench::WithBaseStiffness(d, 1e308); },
              ThrowsMessage<Error>(AllOf(HasSubstr("base"), HasSubstr("1e+308"))));
  EXPECT_THAT([&] { isowrench::WithJointStiffness(d, "knee_rx", 2e15); },
              ThrowsMessage<Error>(AllOf(HasSubstr("knee_rx"), HasSubstr("2e+15"))));
  isowrench::Vector6d s = isowrench::Vector6d::Constant(1e7);
  s[3] = 1e200;
  EXPECT_THAT([&] { isowrench::WithTransducerStiffness(d, s); },
              ThrowsMessage<Error>(AllOf(HasSubstr("rx"), HasSubstr("1e+200"))));
  // A description built in code and handed straight to Model is checked too.
  isowrench::LimbDescription big = d;
  big.joints[4].stiffness = 1e300;
  EXPECT_THAT([&] { isowrench::Model m(big); }, ThrowsMessage<Error>(HasSubstr("1e+300")));
}

TEST(StiffnessRange, TheMaximumItselfSolvesWithoutOverflow) {
  // At kMaxStiffness the statics is finite: K = J^T S J stays far from DBL_MAX.
  isowrench::LimbDescription d = isowrench::ReadUrdfString(Rat5Text(), "rat5");
  d = isowrench::WithTransducerStiffness(d,
                                         isowrench::Vector6d::Constant(isowrench::kMaxStiffness));
  d = isowrench::WithBaseStiffness(d, isowrench::kMaxStiffness);
  isowrench::Model m(d);
  isowrench::WrenchEvaluation e = isowrench::EvaluateWrench(m, m.nominal_posture(), "GP");
  EXPECT_TRUE(e.statics.ok()) << e.statics.message;
  EXPECT_TRUE(e.statics.wrench.allFinite());
  EXPECT_GT(e.statics.wrench.norm(), 0.0);
}

// ---- defect 6: implausible dimensions ----------------------------------------------------

TEST(Dimensions, ShippedModelsDoNotWarn) {
  for (const char* file : {"rat_hindlimb_5dof.urdf", "rat_hindlimb_6dof.urdf",
                           "rat_hindlimb_5dof_base.urdf", "planar_2r.urdf", "planar_4r.urdf"}) {
    isowrench::WarningCollector warnings;
    isowrench::ReadUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/" + file);
    EXPECT_EQ(warnings.text(), "") << file;
  }
}

TEST(Dimensions, FemurInMillimetresWarnsNamingTheJoint) {
  // 31 where 0.031 m was meant: the femur becomes 31 m, GP's length about 31 m too.
  std::string xml = Replace(Rat5Text(), R"(<origin xyz="0.031 0 0")", R"(<origin xyz="31 0 0")");
  isowrench::WarningCollector warnings;
  isowrench::ReadUrdfString(xml, "mm.urdf");
  EXPECT_THAT(warnings.text(), AllOf(HasSubstr("mm.urdf:27"), HasSubstr("knee_rz"),
                                     HasSubstr("31 m"), HasSubstr("plausible segment length")));
  EXPECT_THAT(warnings.text(), HasSubstr("muscle 'GP'"));
}

TEST(Dimensions, TinyEndpointOffsetWarns) {
  std::string xml =
      Replace(Rat5Text(), R"(link="tibia" xyz="0.041 0 0")", R"(link="tibia" xyz="0.000041 0 0")");
  isowrench::WarningCollector warnings;
  isowrench::ReadUrdfString(xml, "um.urdf");
  EXPECT_THAT(warnings.text(), AllOf(HasSubstr("endpoint"), HasSubstr("4.1e-05 m")));
  EXPECT_THAT(warnings.text(), Not(HasSubstr("knee_rz")));
}

}  // namespace
