// A muscle's force model in the description: read from .osim (OpenSim property names, the
// document's <defaults>, OpenSim's class defaults and checks), written to and read from URDF
// (round trip), and bad input with file:line, muscle and value.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "isowrench/error.hpp"
#include "isowrench/model.hpp"
#include "isowrench/muscle.hpp"
#include "isowrench/opensim.hpp"

namespace isowrench {
namespace {

using ::testing::AllOf;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// A two-body OpenSim 4 model (ground -> thigh -> shank, pin joints) with `muscles` in its
// ForceSet and `defaults` in its <defaults>.
std::string Osim(const std::string& muscles, const std::string& defaults = "") {
  return R"(<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
  <Model name="forces">
    <defaults>)" +
         defaults + R"(</defaults>
    <Ground name="ground"/>
    <BodySet name="bodyset"><objects>
      <Body name="thigh"><mass>0.01</mass></Body>
      <Body name="shank"><mass>0.01</mass></Body>
    </objects></BodySet>
    <JointSet name="jointset"><objects>
      <PinJoint name="hip">
        <socket_parent_frame>ground_offset</socket_parent_frame>
        <socket_child_frame>thigh_offset</socket_child_frame>
        <coordinates><Coordinate name="hip_angle"><range>-1 1</range></Coordinate></coordinates>
        <frames>
          <PhysicalOffsetFrame name="ground_offset"><socket_parent>/ground</socket_parent></PhysicalOffsetFrame>
          <PhysicalOffsetFrame name="thigh_offset"><socket_parent>/bodyset/thigh</socket_parent></PhysicalOffsetFrame>
        </frames>
      </PinJoint>
      <PinJoint name="knee">
        <socket_parent_frame>thigh_offset</socket_parent_frame>
        <socket_child_frame>shank_offset</socket_child_frame>
        <coordinates><Coordinate name="knee_angle"><range>-2 0</range></Coordinate></coordinates>
        <frames>
          <PhysicalOffsetFrame name="thigh_offset"><socket_parent>/bodyset/thigh</socket_parent><translation>0 -0.035 0</translation></PhysicalOffsetFrame>
          <PhysicalOffsetFrame name="shank_offset"><socket_parent>/bodyset/shank</socket_parent></PhysicalOffsetFrame>
        </frames>
      </PinJoint>
    </objects></JointSet>
    <ForceSet name="forceset"><objects>)" +
         muscles + R"(</objects></ForceSet>
  </Model>
</OpenSimDocument>
)";
}

// A muscle from the ground to the shank with `body` as its property elements.
std::string Muscle(const std::string& type, const std::string& name, const std::string& body) {
  return "<" + type + " name=\"" + name + R"(">
        <GeometryPath name="path"><PathPointSet><objects>
          <PathPoint name="p1"><location>0.005 0.004 0</location><socket_parent_frame>/ground</socket_parent_frame></PathPoint>
          <PathPoint name="p2"><location>0.002 -0.01 0</location><socket_parent_frame>/bodyset/shank</socket_parent_frame></PathPoint>
        </objects></PathPointSet></GeometryPath>
        <max_isometric_force>2.5</max_isometric_force>)" +
         body + "</" + type + ">\n";
}

OpenSimImport Import(const std::string& xml) {
  OpenSimImportOptions options;
  options.clamp_body = "ground";
  options.endpoint_body = "shank";
  return ImportOpenSimString(xml, "forces.osim", options);
}

const MuscleSpec& Find(const LimbDescription& d, const std::string& name) {
  for (const MuscleSpec& m : d.muscles) {
    if (m.name == name) return m;
  }
  throw std::runtime_error("no muscle " + name);
}

TEST(MuscleImport, MillardPropertiesAndCurveObjectsAreImported) {
  const std::string gp = Muscle("Millard2012EquilibriumMuscle", "GP", R"(
        <optimal_fiber_length>0.0293</optimal_fiber_length>
        <tendon_slack_length>0.0063940545722263415</tendon_slack_length>
        <pennation_angle_at_optimal>0.052359877559829883</pennation_angle_at_optimal>
        <maximum_pennation_angle>1.2</maximum_pennation_angle>
        <ignore_tendon_compliance>false</ignore_tendon_compliance>
        <fiber_damping>0</fiber_damping>
        <minimum_activation>0.02</minimum_activation>
        <ActiveForceLengthCurve name="GP_ActiveForceLengthCurve">
          <minimum_value>0.2</minimum_value>
          <transition_norm_fiber_length>0.7</transition_norm_fiber_length>
        </ActiveForceLengthCurve>
        <FiberForceLengthCurve name="GP_FiberForceLengthCurve">
          <strain_at_one_norm_force>0.6</strain_at_one_norm_force>
          <stiffness_at_low_force>0.3</stiffness_at_low_force>
          <stiffness_at_one_norm_force>4</stiffness_at_one_norm_force>
          <curviness>0.6</curviness>
        </FiberForceLengthCurve>
        <TendonForceLengthCurve name="GP_TendonForceLengthCurve">
          <strain_at_one_norm_force>0.04</strain_at_one_norm_force>
          <stiffness_at_one_norm_force />
        </TendonForceLengthCurve>)");
  const std::string cf = Muscle("Millard2012EquilibriumMuscle", "CF", R"(
        <optimal_fiber_length>0.0379</optimal_fiber_length>
        <tendon_slack_length>0</tendon_slack_length>
        <ignore_tendon_compliance>true</ignore_tendon_compliance>)");
  const OpenSimImport imported = Import(Osim(gp + cf));
  const MuscleForceSpec& f = Find(imported.description, "GP").force;
  EXPECT_EQ(f.model, ForceModelType::kMillard2012);
  EXPECT_EQ(f.optimal_fiber_length, 0.0293);
  EXPECT_EQ(f.tendon_slack_length, 0.0063940545722263415);
  EXPECT_EQ(f.pennation_angle_at_optimal, 0.052359877559829883);
  EXPECT_EQ(f.maximum_pennation_angle, 1.2);
  EXPECT_FALSE(f.ignore_tendon_compliance);
  EXPECT_EQ(f.fiber_damping, 0.0);
  EXPECT_EQ(f.minimum_activation, 0.02);
  EXPECT_EQ(f.active_force_length.minimum_value, 0.2);
  EXPECT_EQ(f.active_force_length.transition_norm_fiber_length, 0.7);
  EXPECT_EQ(f.active_force_length.max_norm_active_fiber_length, 1.8123);  // OpenSim default
  EXPECT_EQ(f.fiber_force_length.strain_at_zero_force, 0.0);
  EXPECT_EQ(f.fiber_force_length.strain_at_one_norm_force, 0.6);
  EXPECT_EQ(f.fiber_force_length.stiffness_at_low_force, 0.3);
  EXPECT_EQ(f.fiber_force_length.stiffness_at_one_norm_force, 4.0);
  EXPECT_EQ(f.fiber_force_length.curviness, 0.6);
  EXPECT_EQ(f.tendon_force_length.strain_at_one_norm_force, 0.04);
  EXPECT_FALSE(f.tendon_force_length.stiffness_at_one_norm_force.has_value());  // empty element
  const MuscleForceSpec& c = Find(imported.description, "CF").force;
  EXPECT_TRUE(c.ignore_tendon_compliance);
  EXPECT_EQ(c.tendon_slack_length, 0.0);
  // A rigid Millard tendon of slack length 0 is an ordinary OpenSim model: no warning.
  EXPECT_THAT(imported.warnings, Not(Contains(HasSubstr("'CF'"))));
  // The report's muscle table names the force model.
  const std::string report = FormatOpenSimReport(imported);
  EXPECT_THAT(report, AllOf(HasSubstr("force model"), HasSubstr("millard2012 compliant"),
                            HasSubstr("millard2012 rigid")));
}

TEST(MuscleImport, ThelenWithZeroTendonSlackLengthIsFlaggedPerMuscle) {
  // As every muscle of RatHindlimb's rat_hindlimb.osim.
  const std::string body = R"(
        <optimal_fiber_length>0.0287</optimal_fiber_length>
        <tendon_slack_length>0</tendon_slack_length>
        <pennation_angle_at_optimal>0.05759587</pennation_angle_at_optimal>
        <FmaxTendonStrain>0.033</FmaxTendonStrain>
        <KshapeActive>0.5</KshapeActive>
        <KshapePassive>4</KshapePassive>)";
  const OpenSimImport imported = Import(
      Osim(Muscle("Thelen2003Muscle", "R_GP", body) + Muscle("Thelen2003Muscle", "R_GA", body)));
  const MuscleForceSpec& f = Find(imported.description, "R_GP").force;
  EXPECT_EQ(f.model, ForceModelType::kThelen2003);
  EXPECT_EQ(f.thelen.FmaxTendonStrain, 0.033);
  EXPECT_EQ(f.thelen.FmaxMuscleStrain, 0.6);  // OpenSim default
  EXPECT_EQ(f.thelen.KshapeActive, 0.5);
  EXPECT_EQ(f.thelen.KshapePassive, 4.0);
  for (const char* name : {"'R_GP'", "'R_GA'"}) {
    EXPECT_THAT(
        imported.warnings,
        Contains(AllOf(HasSubstr(name), HasSubstr("tendon_slack_length is 0"),
                       HasSubstr("rigid-tendon limit"), HasSubstr("OpenSim gives no force"))));
  }
  EXPECT_THAT(FormatOpenSimReport(imported), HasSubstr("thelen2003 rigid-tendon limit"));
}

TEST(MuscleImport, MissingPropertiesComeFromTheDocumentDefaults) {
  // OpenSim registers each object in <defaults> as the default instance of its type
  // (Object::updateDefaultObjectsFromXMLNode): properties a muscle leaves out take its values,
  // then the class defaults (Muscle: optimal_fiber_length 0.1, tendon_slack_length 0.2).
  const std::string defaults = R"(
      <Thelen2003Muscle name="default">
        <tendon_slack_length>0.01</tendon_slack_length>
        <FmaxMuscleStrain>0.5</FmaxMuscleStrain>
      </Thelen2003Muscle>
      <Millard2012EquilibriumMuscle name="default">
        <fiber_damping>0</fiber_damping>
        <TendonForceLengthCurve><strain_at_one_norm_force>0.03</strain_at_one_norm_force></TendonForceLengthCurve>
      </Millard2012EquilibriumMuscle>
      <FiberForceLengthCurve name="default"><strain_at_one_norm_force>0.5</strain_at_one_norm_force></FiberForceLengthCurve>)";
  const std::string muscles =
      Muscle("Thelen2003Muscle", "T", "<optimal_fiber_length>0.02</optimal_fiber_length>") +
      Muscle("Millard2012EquilibriumMuscle", "M", "<FiberForceLengthCurve/>") +
      Muscle("Millard2012EquilibriumMuscle", "D", "");
  const OpenSimImport imported = Import(Osim(muscles, defaults));
  const MuscleForceSpec& t = Find(imported.description, "T").force;
  EXPECT_EQ(t.optimal_fiber_length, 0.02);
  EXPECT_EQ(t.tendon_slack_length, 0.01);
  EXPECT_EQ(t.thelen.FmaxMuscleStrain, 0.5);
  const MuscleForceSpec& m = Find(imported.description, "M").force;
  EXPECT_EQ(m.optimal_fiber_length, 0.1);
  EXPECT_EQ(m.tendon_slack_length, 0.2);
  EXPECT_EQ(m.fiber_damping, 0.0);
  EXPECT_EQ(m.tendon_force_length.strain_at_one_norm_force, 0.03);
  EXPECT_EQ(m.fiber_force_length.strain_at_one_norm_force, 0.5);
  EXPECT_EQ(Find(imported.description, "D").force, m);
}

TEST(MuscleImport, OtherMuscleTypesGetTheConstantModelWithAWarning) {
  const OpenSimImport imported = Import(Osim(Muscle("RigidTendonMuscle", "RT", "")));
  EXPECT_EQ(Find(imported.description, "RT").force.model, ForceModelType::kConstant);
  EXPECT_THAT(imported.warnings, Contains(AllOf(HasSubstr("'RT'"), HasSubstr("RigidTendonMuscle"),
                                                HasSubstr("constant force model"))));
}

TEST(MuscleImport, ParametersOpenSimRejectsAreErrorsWithFileLineMuscleAndValue) {
  const std::string bad_curve = Muscle("Millard2012EquilibriumMuscle", "R_VL", R"(
        <optimal_fiber_length>0.0198</optimal_fiber_length>
        <tendon_slack_length>0.0245</tendon_slack_length>
        <TendonForceLengthCurve><strain_at_one_norm_force>-0.01</strain_at_one_norm_force></TendonForceLengthCurve>)");
  EXPECT_THAT([&] { Import(Osim(bad_curve)); },
              ThrowsMessage<Error>(AllOf(HasSubstr("forces.osim:"), HasSubstr("R_VL"),
                                         HasSubstr("strain_at_one_norm_force -0.01"),
                                         HasSubstr("OpenSim refuses"))));
  const std::string zero =
      Muscle("Thelen2003Muscle", "R_TA", "<optimal_fiber_length>0</optimal_fiber_length>");
  EXPECT_THAT([&] { Import(Osim(zero)); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("R_TA"), HasSubstr("optimal_fiber_length 0 m must be > 0"))));
  const std::string text =
      Muscle("Thelen2003Muscle", "R_TA", "<optimal_fiber_length>long</optimal_fiber_length>");
  EXPECT_THAT([&] { Import(Osim(text)); },
              ThrowsMessage<Error>(AllOf(HasSubstr("forces.osim:"), HasSubstr("'long'"))));
}

// ---- URDF -------------------------------------------------------------------------------

std::string Urdf(const std::string& muscle) {
  return R"(<robot name="leg" xmlns:isowrench="isowrench">
  <link name="ground"/><link name="shank"/>
  <joint name="knee" type="revolute"><parent link="ground"/><child link="shank"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="0" effort="1" velocity="1"/></joint>
  <isowrench:transducer link="shank" xyz="0 -0.03 0"/>
)" + muscle +
         R"(
</robot>
)";
}

const char* const kPoints = R"(<isowrench:point link="ground" xyz="0.005 0.004 0"/>
    <isowrench:point link="shank" xyz="0.002 -0.01 0"/>)";

TEST(MuscleUrdf, ForceModelAttributesAndCurveElementsAreRead) {
  const LimbDescription d = ReadUrdfString(
      Urdf(std::string(R"(<isowrench:muscle name="GP" max_force="2.35" model="millard2012"
      optimal_fiber_length="0.0293" tendon_slack_length="0.0064" pennation_angle_at_optimal="0.05"
      fiber_damping="0.2">
    <isowrench:tendon_force_length strain_at_one_norm_force="0.04" stiffness_at_one_norm_force="40"
        norm_force_at_toe_end="0.5" curviness="0.4"/>
    )") + kPoints +
           "</isowrench:muscle>"),
      "leg.urdf");
  const MuscleForceSpec& f = d.muscles.at(0).force;
  EXPECT_EQ(f.model, ForceModelType::kMillard2012);
  EXPECT_EQ(f.optimal_fiber_length, 0.0293);
  EXPECT_EQ(f.tendon_slack_length, 0.0064);
  EXPECT_EQ(f.pennation_angle_at_optimal, 0.05);
  EXPECT_EQ(f.fiber_damping, 0.2);
  EXPECT_EQ(f.tendon_force_length.strain_at_one_norm_force, 0.04);
  EXPECT_EQ(f.tendon_force_length.norm_force_at_toe_end, 0.5);
  EXPECT_EQ(d.muscles.at(0).path.size(), 2u);
  // Without a model attribute: the constant model.
  const LimbDescription c =
      ReadUrdfString(Urdf(std::string(R"(<isowrench:muscle name="GP" max_force="2.35">)") +
                          kPoints + "</isowrench:muscle>"),
                     "leg.urdf");
  EXPECT_EQ(c.muscles.at(0).force, MuscleForceSpec{});
}

TEST(MuscleUrdf, WriterRoundTripsEveryForceModel) {
  LimbDescription d =
      ReadUrdfString(Urdf(std::string(R"(<isowrench:muscle name="A" max_force="2">)") + kPoints +
                          "</isowrench:muscle>"),
                     "leg.urdf");
  const MuscleSpec base = d.muscles.at(0);
  MuscleSpec millard = base, rigid = base, thelen = base, plain = base;
  millard.name = "M";
  millard.force.model = ForceModelType::kMillard2012;
  millard.force.optimal_fiber_length = 0.0293;
  millard.force.tendon_slack_length = 0.0063940545722263415;
  millard.force.pennation_angle_at_optimal = 0.052359877559829883;
  millard.force.minimum_activation = 0.02;
  millard.force.fiber_damping = 0.0;
  millard.force.active_force_length.minimum_value = 0.15;
  millard.force.fiber_force_length.stiffness_at_low_force = 0.3;
  millard.force.fiber_force_length.stiffness_at_one_norm_force = 4.0;
  millard.force.fiber_force_length.curviness = 0.6;
  millard.force.tendon_force_length.strain_at_one_norm_force = 0.04;
  rigid.name = "R";
  rigid.force = millard.force;
  rigid.force.ignore_tendon_compliance = true;
  rigid.force.tendon_slack_length = 0.0;
  thelen.name = "T";
  thelen.force.model = ForceModelType::kThelen2003;
  thelen.force.optimal_fiber_length = 0.0287;
  thelen.force.maximum_pennation_angle = 1.3;
  thelen.force.thelen.FmaxTendonStrain = 0.033;
  thelen.force.thelen.KshapePassive = 4.0;
  plain.name = "C";
  d.muscles = {millard, rigid, thelen, plain};
  const std::string written = WriteUrdfString(d);
  EXPECT_THAT(written, AllOf(HasSubstr(R"(model="millard2012" optimal_fiber_length="0.0293")"),
                             HasSubstr(R"(ignore_tendon_compliance="true")"),
                             HasSubstr("<isowrench:fiber_force_length"),
                             HasSubstr(R"(<isowrench:thelen2003_curves FmaxTendonStrain=")"),
                             HasSubstr(R"(<isowrench:muscle name="C" max_force="2">)")));
  const LimbDescription back = ReadUrdfString(written, "written.urdf");
  ASSERT_EQ(back.muscles.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(back.muscles[i].force, d.muscles[i].force) << d.muscles[i].name;
  }
  LimbDescription again = back;
  again.source = d.source;
  EXPECT_EQ(WriteUrdfString(again), written);
}

TEST(MuscleUrdf, BadForceModelInputIsAnErrorWithLineMuscleAndValue) {
  auto read = [](const std::string& open, const std::string& children = "") {
    ReadUrdfString(Urdf(open + "\n    " + children + kPoints + "</isowrench:muscle>"), "leg.urdf");
  };
  EXPECT_THAT([&] { read(R"(<isowrench:muscle name="GP" max_force="2" model="hill">)"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("leg.urdf:6"), HasSubstr("'GP'"),
                                         HasSubstr("unknown force model 'hill'"))));
  EXPECT_THAT(
      [&] {
        read(
            R"(<isowrench:muscle name="GP" max_force="2" model="thelen2003" tendon_slack_length="0">)");
      },
      ThrowsMessage<Error>(HasSubstr("needs the attribute 'optimal_fiber_length'")));
  EXPECT_THAT(
      [&] {
        read(
            R"(<isowrench:muscle name="GP" max_force="2" model="thelen2003" optimal_fiber_length="0" tendon_slack_length="0">)");
      },
      ThrowsMessage<Error>(AllOf(HasSubstr("leg.urdf:6"), HasSubstr("'GP'"),
                                 HasSubstr("optimal_fiber_length 0 m must be > 0"))));
  EXPECT_THAT(
      [&] { read(R"(<isowrench:muscle name="GP" max_force="2" optimal_fiber_length="0.03">)"); },
      ThrowsMessage<Error>(HasSubstr("needs model=")));
  EXPECT_THAT(
      [&] {
        read(
            R"(<isowrench:muscle name="GP" max_force="2" model="thelen2003" optimal_fiber_length="0.03" tendon_slack_length="0">)",
            R"(<isowrench:tendon_force_length strain_at_one_norm_force="0.04"/>)");
      },
      ThrowsMessage<Error>(HasSubstr("belongs to model=\"millard2012\"")));
  EXPECT_THAT(
      [&] {
        read(
            R"(<isowrench:muscle name="GP" max_force="2" model="millard2012" optimal_fiber_length="0.03" tendon_slack_length="0">)",
            R"(<isowrench:tendon_force_length strain="0.04"/>)");
      },
      ThrowsMessage<Error>(HasSubstr("has no attribute 'strain'")));
  EXPECT_THAT(
      [&] {
        read(
            R"(<isowrench:muscle name="GP" max_force="2" model="millard2012" optimal_fiber_length="0.03" tendon_slack_length="0" ignore_tendon_compliance="yes">)");
      },
      ThrowsMessage<Error>(HasSubstr("ignore_tendon_compliance 'yes' must be true or false")));
  EXPECT_THAT(
      [&] {
        read(
            R"(<isowrench:muscle name="GP" max_force="2" model="millard2012" optimal_fiber_length="0.03" tendon_slack_length="0.01">)",
            R"(<isowrench:active_force_length minimum_value="-0.5"/>)");
      },
      ThrowsMessage<Error>(AllOf(HasSubstr("leg.urdf:6"), HasSubstr("ActiveForceLengthCurve"))));
}

TEST(MuscleModel, ModelRefusesAForceModelOpenSimRejects) {
  LimbDescription d =
      ReadUrdfString(Urdf(std::string(R"(<isowrench:muscle name="GP" max_force="2">)") + kPoints +
                          "</isowrench:muscle>"),
                     "leg.urdf");
  d.muscles[0].force.model = ForceModelType::kMillard2012;
  d.muscles[0].force.optimal_fiber_length = -0.03;
  EXPECT_THAT(
      [&] { Model model(d); },
      ThrowsMessage<Error>(AllOf(HasSubstr("GP"), HasSubstr("optimal_fiber_length -0.03"))));
}

}  // namespace
}  // namespace isowrench
