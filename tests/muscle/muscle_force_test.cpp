// The isometric force models against independent references: hand-derived Thelen2003
// equilibria, the equilibrium residual recomputed from the public curves, the rigid-tendon
// limit of a stiff compliant tendon, dF/dL_MT against central differences, the scenarios of
// opensim-core's OpenSim/Actuators/Test/testMuscles.cpp, and bad input.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <vector>

#include "isowrench/error.hpp"
#include "isowrench/muscle.hpp"

namespace isowrench {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

// Thelen2003Muscle::calcfse constants for FmaxTendonStrain e0: the toe ends at
// eToe = 99 e0 e^3 / (166 e^3 - 67) with force 0.33; the line beyond has slope
// klin = 0.67 / (e0 - eToe).
struct ThelenTendon {
  double toe, slope;
  explicit ThelenTendon(double e0) {
    const double e3 = std::exp(3.0);
    toe = 99 * e0 * e3 / (166 * e3 - 67);
    slope = 0.67 / (e0 - toe);
  }
};

MuscleForceSpec ThelenSpec(double ofl, double tsl, double pennation = 0.0) {
  MuscleForceSpec s;
  s.model = ForceModelType::kThelen2003;
  s.optimal_fiber_length = ofl;
  s.tendon_slack_length = tsl;
  s.pennation_angle_at_optimal = pennation;
  return s;
}

MuscleForceSpec MillardSpec(double ofl, double tsl, double pennation = 0.0) {
  MuscleForceSpec s;
  s.model = ForceModelType::kMillard2012;
  s.optimal_fiber_length = ofl;
  s.tendon_slack_length = tsl;
  s.pennation_angle_at_optimal = pennation;
  return s;
}

TEST(MuscleForce, ThelenEquilibriumMatchesHandDerivationShortFiber) {
  // Hand derivation (Thelen2003Muscle, defaults FmaxTendonStrain 0.04, KshapeActive 0.45,
  // no pennation), max_force 100 N, l_o = 0.1 m, l_Ts = 0.2 m, a = 1. Pick the fiber length
  // l* = 0.09 m (l/l_o = 0.9, below optimal: no passive force):
  //   f_L = exp(-(0.9 - 1)^2 / 0.45) = exp(-0.0222...) = 0.9780228724846005
  //   F*  = 100 a f_L = 97.80228724846005 N
  // The tendon carries F*; 0.978 > 0.33, so it is on Thelen's line:
  //   eToe = 99*0.04 e^3 / (166 e^3 - 67) = 0.024344621515035,  klin = 0.67/(0.04 - eToe) =
  //   42.796793488158585,  strain = eToe + (F*/100 - 0.33) / klin = 0.03948647723990162
  //   L_MT = l* + l_Ts (1 + strain) = 0.29789729544798027 m.
  // So Evaluate(L_MT, 1) must return l*, F* and that strain. The series stiffness:
  //   K_M = 100 d f_L/dl = 100 * (2 * 0.1 / 0.45) f_L / 0.1 = 434.6768 N/m,
  //   K_T = 100 klin / 0.2 = 21398.397 N/m,  dF/dL = K_M K_T / (K_M + K_T) = 426.0228 N/m.
  const ThelenTendon tendon(0.04);
  const double fal = std::exp(-0.01 / 0.45);
  const double force = 100 * fal;
  const double strain = tendon.toe + (fal - 0.33) / tendon.slope;
  const double length = 0.09 + 0.2 * (1 + strain);
  EXPECT_NEAR(length, 0.29789729544798027, 1e-15);  // the numbers written above
  const MuscleForce f = MuscleForceModel("T", 100, ThelenSpec(0.1, 0.2)).Evaluate(length, 1.0);
  EXPECT_EQ(f.status, MuscleForceStatus::kEquilibrium);
  EXPECT_NEAR(f.fiber_length, 0.09, 1e-14);
  EXPECT_NEAR(f.force, force, 1e-11);
  EXPECT_NEAR(f.active_force, force, 1e-11);
  EXPECT_EQ(f.passive_force, 0.0);
  EXPECT_NEAR(f.tendon_strain, strain, 1e-13);
  EXPECT_EQ(f.pennation_angle, 0.0);
  const double km = 100 * (2 * 0.1 / 0.45) * fal / 0.1, kt = 100 * tendon.slope / 0.2;
  EXPECT_NEAR(f.stiffness, km * kt / (km + kt), 1e-9);
  EXPECT_NEAR(f.stiffness, 426.0228079523928, 1e-9);
  EXPECT_FALSE(f.opensim_gives_no_number);
}

TEST(MuscleForce, ThelenEquilibriumMatchesHandDerivationPennatedStretchedFiber) {
  // Pennated, stretched fiber: l_o = 0.1 m, pennation at optimal 0.3 rad, l_Ts = 0.2 m,
  // max_force 100 N, a = 0.5, defaults KshapePassive 5, FmaxMuscleStrain 0.6. Pick l* = 0.12 m:
  //   h = l_o sin(0.3) = 0.029552020666134 (constant-width pennation), sin(phi) = h/l* =
  //   0.2462668388844, cos(phi) = 0.9692020656529, phi = 0.2488265706211 rad
  //   f_L = exp(-0.2^2/0.45) = 0.914947228730031
  //   f_PE = (exp(5 * 0.2 / 0.6) - 1) / (e^5 - 1) = 0.029132338500946
  //   F* = 100 (0.5 f_L + f_PE) cos(phi) = 47.16194946766904 N (tendon: on the line)
  //   strain = eToe + (F*/100 - 0.33) / klin = 0.02765373612699496
  //   L_MT = l* cos(phi) + l_Ts (1 + strain) = 0.3218349951037478 m.
  const ThelenTendon tendon(0.04);
  const double h = 0.1 * std::sin(0.3), s = h / 0.12, c = std::sqrt(1 - s * s);
  const double fal = std::exp(-0.04 / 0.45);
  const double fpe = (std::exp(5 * 0.2 / 0.6) - 1) / (std::exp(5.0) - 1);
  const double force = 100 * (0.5 * fal + fpe) * c;
  const double strain = tendon.toe + (force / 100 - 0.33) / tendon.slope;
  const double length = 0.12 * c + 0.2 * (1 + strain);
  EXPECT_NEAR(length, 0.3218349951037478, 1e-15);
  const MuscleForce f = MuscleForceModel("T", 100, ThelenSpec(0.1, 0.2, 0.3)).Evaluate(length, 0.5);
  EXPECT_EQ(f.status, MuscleForceStatus::kEquilibrium);
  EXPECT_NEAR(f.fiber_length, 0.12, 1e-14);
  EXPECT_NEAR(f.force, force, 1e-11);
  EXPECT_NEAR(f.force, 47.16194946766904, 1e-11);
  EXPECT_NEAR(f.active_force, 100 * 0.5 * fal * c, 1e-11);
  EXPECT_NEAR(f.passive_force, 100 * fpe * c, 1e-11);
  EXPECT_NEAR(f.pennation_angle, 0.24882657062107658, 1e-13);
  EXPECT_NEAR(f.tendon_strain, strain, 1e-13);
}

TEST(MuscleForce, ThelenMinimumActivationClampsTheActivation) {
  // Thelen2003Muscle computes with clampActivation(a) = clamp(minimum_activation, a, 1).
  const MuscleForceModel m("T", 100, ThelenSpec(0.1, 0.2));
  const MuscleForce zero = m.Evaluate(0.3, 0.0), floor = m.Evaluate(0.3, 0.01);
  EXPECT_EQ(zero.activation, 0.01);
  EXPECT_EQ(zero.force, floor.force);
  EXPECT_GT(zero.active_force, 0.0);
  EXPECT_GT(m.Evaluate(0.3, 0.02).force, zero.force);
}

// |fiber force along the tendon - tendon force| from the public curves alone, at the
// returned fiber length (an independent recomputation of the residual).
double Residual(const MuscleForceModel& m, const MuscleForceSpec& s, double length,
                const MuscleForce& f) {
  const double l = f.fiber_length, lo = s.optimal_fiber_length;
  const double h =
      s.pennation_angle_at_optimal > 0 ? lo * std::sin(s.pennation_angle_at_optimal) : 0.0;
  const double cos_phi = std::cos(f.pennation_angle);
  EXPECT_NEAR(std::sin(f.pennation_angle), h / l, 1e-12);
  const double fiber =
      m.max_force() *
      (f.activation * m.ActiveForceLength(l / lo).value + m.PassiveForceLength(l / lo).value) *
      cos_phi;
  const double tendon =
      m.max_force() * m.TendonForceLength((length - l * cos_phi) / s.tendon_slack_length).value;
  return fiber - tendon;
}

// Millard and Thelen muscles shaped like the rat models (l_o, l_Ts, pennation, max force).
std::vector<MuscleForceSpec> RatLikeSpecs() {
  return {MillardSpec(0.0293, 0.00639, 0.0524), MillardSpec(0.0198, 0.0245, 0.244),
          MillardSpec(0.0042, 0.0086, 0.314),   MillardSpec(0.0206, 0.00034, 0.192),
          ThelenSpec(0.0287, 0.0064, 0.0576),   ThelenSpec(0.0149, 0.025, 0.164)};
}

// Tension (the engine's force stage) is Evaluate's force and status to the last bit: every
// model kind (rigid and compliant Millard2012, Thelen2003, a zero tendon slack length), slack
// and minimum-length postures, activations at and below the floor, and lengths so absurd that
// Evaluate's field check decides (Tension then runs Evaluate).
TEST(MuscleForce, TensionIsEvaluatesForceBitForBit) {
  std::vector<MuscleForceSpec> specs = RatLikeSpecs();
  for (MuscleForceSpec spec : RatLikeSpecs()) {
    spec.ignore_tendon_compliance = true;
    specs.push_back(spec);
  }
  std::map<MuscleForceStatus, int> seen;
  for (const MuscleForceSpec& spec : specs) {
    const MuscleForceModel m("R", 10.0, spec);
    const double span = spec.optimal_fiber_length + spec.tendon_slack_length;
    std::vector<double> lengths = {1e-300, 1e200, 1e300, std::numeric_limits<double>::max()};
    for (double x = 0.05; x <= 3.0; x += 0.0037) lengths.push_back(x * span);
    for (double length : lengths) {
      for (double a : {0.0, 0.005, 0.3, 1.0}) {
        const MuscleForce f = m.Evaluate(length, a);
        MuscleForceStatus status = MuscleForceStatus::kEquilibrium;
        const double tension = m.Tension(length, a, &status);
        ASSERT_EQ(status, f.status) << ForceModelName(spec.model) << " L " << length << " a " << a;
        ASSERT_EQ(tension, f.force) << ForceModelName(spec.model) << " L " << length << " a " << a;
        ++seen[status];
      }
    }
  }
  EXPECT_GT(seen[MuscleForceStatus::kEquilibrium], 5000);
  EXPECT_GT(seen[MuscleForceStatus::kSlack], 100);
  EXPECT_GT(seen[MuscleForceStatus::kNoEquilibrium], 0);
  MuscleForceStatus status;
  EXPECT_THROW(MuscleForceModel("R", 10.0, RatLikeSpecs()[0]).Tension(0.03, 1.5, &status), Error);
}

// The models of the lane tests: the rat-like ones with compliant and with rigid tendons, a
// classic (undamped) Millard2012 and one with a zero tendon slack length.
std::vector<MuscleForceSpec> LaneTestSpecs() {
  std::vector<MuscleForceSpec> specs = RatLikeSpecs();
  for (MuscleForceSpec spec : RatLikeSpecs()) {
    spec.ignore_tendon_compliance = true;
    specs.push_back(spec);
  }
  MuscleForceSpec classic = MillardSpec(0.0293, 0.00639, 0.0524);
  classic.fiber_damping = 0.0;
  specs.push_back(classic);
  specs.push_back(MillardSpec(0.018, 0.004, 0.0));
  return specs;
}

// A musculotendon length for the lane tests (span = l_o + l_Ts): mostly taut, some slack, near
// the slack length, NaN, negative, zero, huge and far beyond the curves.
double MixedLength(std::mt19937& rng, double span) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double pick = unit(rng);
  return pick < 0.9    ? span * (0.3 + 2.2 * unit(rng))  // mostly taut, some slack
         : pick < 0.93 ? span * (0.9 + 0.2 * unit(rng)) * (1 + 1e-9 * unit(rng))
         : pick < 0.95 ? std::numeric_limits<double>::quiet_NaN()
         : pick < 0.96 ? -span * unit(rng)
         : pick < 0.97 ? 0.0
         : pick < 0.98 ? 1e300
                       : span * 50 * unit(rng);
}

// Tension4 (the batch lanes' force stage, vectorised) is Tension lane by lane to the last bit:
// groups of four random lengths mixing taut, slack, minimum-length, huge, zero, negative and
// NaN lengths and lengths where the model has no number, for every model kind (rigid and
// compliant Millard2012, classic and damped, Thelen2003, a zero tendon slack length, a Thelen
// muscle whose passive curve overflows) at activations at, below and above the floor.
TEST(MuscleForce, Tension4IsTensionPerLaneBitForBit) {
  std::vector<MuscleForceSpec> specs = LaneTestSpecs();
  specs.push_back(ThelenSpec(1e-4, 0.004, 0.1));  // l/l_o in the hundreds: exp overflows
  std::mt19937 rng(28);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::map<MuscleForceStatus, int> seen;
  int mixed = 0;
  for (const MuscleForceSpec& spec : specs) {
    const MuscleForceModel m("R", 10.0, spec);
    const double span = spec.optimal_fiber_length + spec.tendon_slack_length;
    for (int group = 0; group < 1500; ++group) {
      double length[4];
      for (double& L : length) {
        L = MixedLength(rng, span);
      }
      const double a = group % 7 == 0 ? 0.0 : group % 11 == 0 ? 1.0 : unit(rng);
      double force[4];
      MuscleForceStatus status[4];
      m.Tension4(length, a, force, status);
      std::map<MuscleForceStatus, int> group_statuses;
      for (int l = 0; l < 4; ++l) {
        MuscleForceStatus one = MuscleForceStatus::kEquilibrium;
        const double f = m.Tension(length[l], a, &one);
        ASSERT_EQ(status[l], one) << ForceModelName(spec.model) << " L " << length[l] << " a " << a
                                  << " lane " << l;
        std::uint64_t bits_four, bits_one;
        std::memcpy(&bits_four, &force[l], sizeof f);
        std::memcpy(&bits_one, &f, sizeof f);
        ASSERT_EQ(bits_four, bits_one)
            << ForceModelName(spec.model) << " rigid " << m.rigid_tendon() << " L " << length[l]
            << " a " << a << " lane " << l << ": " << force[l] << " vs " << f;
        ++seen[one];
        ++group_statuses[one];
      }
      mixed += group_statuses.size() > 1;
    }
  }
  EXPECT_GT(seen[MuscleForceStatus::kEquilibrium], 40000);
  EXPECT_GT(seen[MuscleForceStatus::kSlack], 5000);
  EXPECT_GT(seen[MuscleForceStatus::kNoEquilibrium], 1000);
  EXPECT_GT(mixed, 10000);
  double length[4] = {0.03, 0.03, 0.03, 0.03}, force[4];
  MuscleForceStatus status[4];
  EXPECT_THROW(MuscleForceModel("R", 10.0, RatLikeSpecs()[0]).Tension4(length, 1.5, force, status),
               Error);
}

// TensionBlock (the batch's force stage over a block: a compliant tendon's taut lengths sorted
// into lane groups) is Tension per length to the last bit: blocks of 0 to 601 lengths (not
// multiples of four; over the 512 it takes at a time) mixing taut, slack, NaN, zero, negative,
// huge and no-equilibrium lengths, for every model kind.
TEST(MuscleForce, TensionBlockIsTensionPerLengthBitForBit) {
  const std::vector<MuscleForceSpec> specs = LaneTestSpecs();
  std::mt19937 rng(2828);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::map<MuscleForceStatus, int> seen;
  const int sizes[] = {0, 1, 3, 5, 7, 13, 37, 514, 601};
  for (const MuscleForceSpec& spec : specs) {
    const MuscleForceModel m("R", 10.0, spec);
    const double span = spec.optimal_fiber_length + spec.tendon_slack_length;
    for (int block = 0; block < 18; ++block) {
      const int n = sizes[block % 9];
      std::vector<double> length(static_cast<size_t>(n)), force(length.size(), -7.0);
      std::vector<MuscleForceStatus> status(length.size(), static_cast<MuscleForceStatus>(99));
      for (double& L : length) {
        L = MixedLength(rng, span);
      }
      const double a = block % 7 == 0 ? 0.0 : block % 5 == 0 ? 1.0 : unit(rng);
      m.TensionBlock(length.data(), n, a, force.data(), status.data());
      for (int i = 0; i < n; ++i) {
        MuscleForceStatus one = MuscleForceStatus::kEquilibrium;
        const double f = m.Tension(length[i], a, &one);
        ASSERT_EQ(status[i], one) << ForceModelName(spec.model) << " L " << length[i] << " a " << a
                                  << " entry " << i << " of " << n;
        std::uint64_t bits_stream, bits_one;
        std::memcpy(&bits_stream, &force[i], sizeof f);
        std::memcpy(&bits_one, &f, sizeof f);
        ASSERT_EQ(bits_stream, bits_one)
            << ForceModelName(spec.model) << " rigid " << m.rigid_tendon() << " L " << length[i]
            << " a " << a << " entry " << i << " of " << n << ": " << force[i] << " vs " << f;
        ++seen[one];
      }
    }
  }
  EXPECT_GT(seen[MuscleForceStatus::kEquilibrium], 10000);
  EXPECT_GT(seen[MuscleForceStatus::kSlack], 1000);
  EXPECT_GT(seen[MuscleForceStatus::kNoEquilibrium], 300);
  double length[5] = {0.03, 0.03, 0.03, 0.03, 0.03}, force[5];
  MuscleForceStatus status[5];
  EXPECT_THROW(
      MuscleForceModel("R", 10.0, RatLikeSpecs()[0]).TensionBlock(length, 5, 1.5, force, status),
      Error);
}

TEST(MuscleForce, EquilibriumResidualBelow1e10NewtonAtEverySolution) {
  int solutions = 0;
  double worst = 0;
  for (const MuscleForceSpec& spec : RatLikeSpecs()) {
    const MuscleForceModel m("R", 10.0, spec);
    const double span = spec.optimal_fiber_length + spec.tendon_slack_length;
    for (double x = 0.5; x <= 2.2; x += 0.01) {
      for (double a : {0.0, 0.05, 0.3, 1.0}) {
        const double length = x * span;
        const MuscleForce f = m.Evaluate(length, a);
        ASSERT_TRUE(std::isfinite(f.force) && std::isfinite(f.stiffness));
        if (f.status != MuscleForceStatus::kEquilibrium) continue;
        ++solutions;
        EXPECT_LE(std::abs(f.residual), 1e-10) << x << " " << a;
        const double r = Residual(m, spec, length, f);
        worst = std::max(worst, std::abs(r));
        EXPECT_LE(std::abs(r), 1e-10) << x << " " << a;
        EXPECT_NEAR(f.active_force + f.passive_force, f.force, 1e-10);
      }
    }
  }
  EXPECT_GT(solutions, 2500);
  EXPECT_LT(worst, 1e-10);
}

TEST(MuscleForce, StiffTendonGivesTheRigidTendonForce) {
  // A compliant tendon with strain_at_one_norm_force e stretches by at most
  // delta = l_Ts e (1 + F/max_force) (toe region below max_force, slope 1.375/e above), so its
  // force differs from the rigid tendon's by at most max|dF/dL_rigid| delta.
  MuscleForceSpec rigid = MillardSpec(0.03, 0.02, 0.2);
  rigid.ignore_tendon_compliance = true;
  const MuscleForceModel r("R", 5.0, rigid);
  for (double e : {1e-3, 1e-4, 1e-5}) {
    MuscleForceSpec stiff = MillardSpec(0.03, 0.02, 0.2);
    stiff.tendon_force_length.strain_at_one_norm_force = e;
    const MuscleForceModel c("C", 5.0, stiff);
    double worst_ratio = 0;
    for (double length = 0.04; length < 0.08; length += 0.0005) {
      for (double a : {0.1, 1.0}) {
        const MuscleForce fr = r.Evaluate(length, a), fc = c.Evaluate(length, a);
        if (fr.status != MuscleForceStatus::kEquilibrium) continue;
        ASSERT_EQ(fc.status, MuscleForceStatus::kEquilibrium) << length;
        const double delta = 0.02 * e * (1 + fc.force / 5.0);
        double k = 0;
        for (double d : {-delta, 0.0})
          k = std::max(k, std::abs(r.Evaluate(length + d, a).stiffness));
        const double bound = 1.5 * k * delta + 1e-12;
        EXPECT_LE(std::abs(fc.force - fr.force), bound) << e << " " << length << " " << a;
        worst_ratio = std::max(worst_ratio, std::abs(fc.force - fr.force) / bound);
      }
    }
    EXPECT_GT(worst_ratio, 0.0);
  }
}

TEST(MuscleForce, StiffnessEqualsCentralDifferencesOfTheForce) {
  // Step h = 1e-7 m: truncation h^2 F''' / 6 < 1e-8 N/m here, rounding 2 * 1e-13 * max_force
  // / (2 h) ~ 1e-5 N/m.
  std::vector<MuscleForceSpec> specs = RatLikeSpecs();
  MuscleForceSpec rigid = MillardSpec(0.0293, 0.00639, 0.0524);
  rigid.ignore_tendon_compliance = true;
  specs.push_back(rigid);
  specs.push_back(ThelenSpec(0.0287, 0.0, 0.0576));  // the rigid-tendon limit
  const double h = 1e-7;
  int checked = 0;
  for (const MuscleForceSpec& spec : specs) {
    const MuscleForceModel m("R", 10.0, spec);
    const double span = spec.optimal_fiber_length + spec.tendon_slack_length;
    for (double x = 0.6; x <= 2.0; x += 0.0137) {
      for (double a : {0.02, 0.5, 1.0}) {
        const double length = x * span;
        const MuscleForce f = m.Evaluate(length, a);
        const MuscleForce up = m.Evaluate(length + h, a), down = m.Evaluate(length - h, a);
        if (f.status != MuscleForceStatus::kEquilibrium || up.status != f.status ||
            down.status != f.status) {
          continue;
        }
        // Thelen's passive curve and tendon curve have kinks (slope jumps) at l = l_o and at
        // zero tendon strain: no derivative there.
        if (spec.model == ForceModelType::kThelen2003 &&
            (std::abs(f.fiber_length - spec.optimal_fiber_length) < 1e-5 ||
             std::abs(f.tendon_strain) < 1e-3)) {
          continue;
        }
        const double fd = (up.force - down.force) / (2 * h);
        EXPECT_NEAR(f.stiffness, fd, 1e-4 * (1 + std::abs(fd)))
            << ForceModelName(spec.model) << " L " << length << " a " << a;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1500);
}

TEST(MuscleForce, WarmStartFindsTheColdStartEquilibrium) {
  for (const MuscleForceSpec& spec : RatLikeSpecs()) {
    const MuscleForceModel m("R", 10.0, spec);
    const double span = spec.optimal_fiber_length + spec.tendon_slack_length;
    int cold_iterations = 0, warm_iterations = 0;
    double guess = 0;
    for (double x = 0.8; x <= 1.8; x += 0.005) {
      const MuscleForce cold = m.Evaluate(x * span, 1.0);
      const MuscleForce warm = m.Evaluate(x * span, 1.0, guess);
      EXPECT_EQ(cold.status, warm.status);
      // Both residuals are within 1e-13 max_force = 1e-12 N; the forces then agree to that
      // times k_T / |dr/dl| (<= 100 here).
      EXPECT_NEAR(cold.force, warm.force, 1e-10) << x;
      EXPECT_NEAR(cold.fiber_length, warm.fiber_length, 1e-12) << x;
      cold_iterations += cold.iterations;
      warm_iterations += warm.iterations;
      guess = warm.fiber_length;
    }
    if (!m.rigid_tendon()) {
      EXPECT_LT(warm_iterations, cold_iterations);
    }
  }
}

TEST(MuscleForce, ShortPathIsSlackWithZeroForce) {
  const MuscleForceModel m("R", 10.0, MillardSpec(0.03, 0.02, 0.2));
  // Slack while L_MT <= l_Ts + the minimum fiber length along the tendon: here the active
  // curve's minimum 0.4441 l_o, at pennation asin(h / 0.4441 l_o).
  const double lmin = 0.4441 * 0.03, h = 0.03 * std::sin(0.2);
  const double slack = 0.02 + std::sqrt(lmin * lmin - h * h);
  EXPECT_NEAR(m.minimum_fiber_length(), lmin, 1e-15);
  for (double length : {0.001, 0.02, slack - 1e-9}) {
    const MuscleForce f = m.Evaluate(length, 1.0);
    EXPECT_EQ(f.status, MuscleForceStatus::kSlack) << length;
    EXPECT_EQ(f.force, 0.0);
    EXPECT_EQ(f.stiffness, 0.0);
    EXPECT_EQ(f.fiber_length, lmin);
    EXPECT_LT(f.tendon_strain, 0.0);
  }
  EXPECT_EQ(m.Evaluate(slack + 1e-6, 1.0).status, MuscleForceStatus::kEquilibrium);
}

TEST(MuscleForce, FiberAtMinimumLengthCarriesTheTendonForce) {
  // The classic Hill model (fiber_damping 0) keeps the active curve's floor at 0.1, so at the
  // minimum fiber length the fiber pulls 0.1 a max_force cos(phi): with a barely taut tendon
  // the fiber would have to be shorter still. OpenSim clamps it there
  // (Warning_FiberAtLowerBound) and reports the tendon force at that fiber length.
  MuscleForceSpec spec = MillardSpec(0.1, 0.2, 0.2);
  spec.fiber_damping = 0.0;
  const MuscleForceModel m("U", 1000, spec);
  const double lmin = 0.4441 * 0.1, h = 0.1 * std::sin(0.2);
  const double along = std::sqrt(lmin * lmin - h * h);
  for (double stretch : {1e-4, 1e-3}) {
    const double length = 0.2 + along + stretch;
    const MuscleForce f = m.Evaluate(length, 1.0);
    EXPECT_EQ(f.status, MuscleForceStatus::kFiberAtMinimumLength) << stretch;
    EXPECT_EQ(f.fiber_length, lmin);
    EXPECT_NEAR(f.force, 1000 * m.TendonForceLength(1 + stretch / 0.2).value, 1e-9);
    EXPECT_GT(f.force, 0.0);
    EXPECT_LT(f.force, 1000 * 0.1 * along / lmin);
    EXPECT_EQ(f.active_force, 0.0);
    EXPECT_NEAR(f.stiffness, 1000 * m.TendonForceLength(1 + stretch / 0.2).slope / 0.2, 1e-6);
    // From a guess between the minimum fiber length and the slack-tendon fiber length the
    // bracketed solve finds the same clamp.
    const double slack_fiber = std::sqrt(h * h + (along + stretch) * (along + stretch));
    const MuscleForce w = m.Evaluate(length, 1.0, 0.5 * (lmin + slack_fiber));
    EXPECT_EQ(w.status, MuscleForceStatus::kFiberAtMinimumLength);
    EXPECT_EQ(w.force, f.force);
    EXPECT_EQ(w.stiffness, f.stiffness);
    EXPECT_EQ(f.fiber_length_slope, 0.0);  // the fiber is held at its minimum length
    EXPECT_EQ(w.fiber_length_slope, 0.0);
  }
}

TEST(MuscleForce, ZeroTendonSlackLengthIsTheRigidTendonLimitOpenSimCannotEvaluate) {
  // Every Thelen2003Muscle of RatHindlimb's rat_hindlimb.osim has tendon_slack_length 0:
  // OpenSim divides by it. isowrench computes the rigid-tendon limit, a tendon of zero
  // length: l = sqrt(h^2 + L^2), F = max_force (a f_L + f_PE) cos(phi).
  const MuscleForceModel m("R_GP", 2.4, ThelenSpec(0.0287, 0.0, 0.05759587));
  EXPECT_TRUE(m.rigid_tendon());
  EXPECT_THAT(m.opensim_limitation(),
              AllOf(HasSubstr("tendon_slack_length is 0"), HasSubstr("rigid-tendon limit")));
  const double length = 0.031, h = 0.0287 * std::sin(0.05759587);
  const double l = std::sqrt(h * h + length * length), c = length / l, x = l / 0.0287;
  const double fal = std::exp(-(x - 1) * (x - 1) / 0.45);
  const double fpe = (std::exp(5 * (x - 1) / 0.6) - 1) / (std::exp(5.0) - 1);
  const MuscleForce f = m.Evaluate(length, 0.7);
  EXPECT_EQ(f.status, MuscleForceStatus::kEquilibrium);
  EXPECT_TRUE(f.opensim_gives_no_number);
  EXPECT_NEAR(f.fiber_length, l, 1e-16);
  EXPECT_NEAR(f.force, 2.4 * (0.7 * fal + fpe) * c, 1e-13);
  EXPECT_EQ(f.tendon_strain, 0.0);
  // And it is the limit of ever shorter compliant tendons.
  for (double tsl : {1e-6, 1e-8}) {
    const MuscleForce g = MuscleForceModel("R_GP", 2.4, ThelenSpec(0.0287, tsl, 0.05759587))
                              .Evaluate(length + tsl, 0.7);
    EXPECT_EQ(g.status, MuscleForceStatus::kEquilibrium);
    EXPECT_NEAR(g.force, f.force, 2e3 * tsl) << tsl;
  }
  // A Millard compliant tendon of slack length 0 is the same case; a Millard rigid tendon of
  // slack length 0 is an ordinary OpenSim model.
  EXPECT_FALSE(MuscleForceModel("M", 2, MillardSpec(0.03, 0.0)).opensim_limitation().empty());
  MuscleForceSpec rigid = MillardSpec(0.03, 0.0);
  rigid.ignore_tendon_compliance = true;
  EXPECT_TRUE(MuscleForceModel("M", 2, rigid).opensim_limitation().empty());
  EXPECT_FALSE(MuscleForceModel("M", 2, rigid).Evaluate(0.03, 1).opensim_gives_no_number);
}

TEST(MuscleForce, ThelenRigidTendonIsAModelOpenSimRefuses) {
  MuscleForceSpec spec = ThelenSpec(0.03, 0.01);
  spec.ignore_tendon_compliance = true;
  const MuscleForceModel m("T", 2, spec);
  EXPECT_TRUE(m.rigid_tendon());
  EXPECT_THAT(m.opensim_limitation(), HasSubstr("not implemented for Thelen2003Muscle"));
}

TEST(MuscleForce, OpenSimTestMusclesScenarios) {
  // opensim-core OpenSim/Actuators/Test/testMuscles.cpp, path from (0,0,0) to (0,0,1): L = 1 m.
  // "Test extremely short fiber where muscle should still initialize": Millard, l_o = 0.01,
  // l_Ts = 100, a = 1 (the path is shorter than the tendon: slack, no force).
  const MuscleForce longTendon =
      MuscleForceModel("muscle", 1, MillardSpec(0.01, 100.0)).Evaluate(1.0, 1.0);
  EXPECT_EQ(longTendon.status, MuscleForceStatus::kSlack);
  EXPECT_EQ(longTendon.force, 0.0);
  // "Test extremely short (but stretched) fiber, which should still initialize": l_Ts = 0.1,
  // a = 0.01.
  const MuscleForceModel stretched("muscle", 1, MillardSpec(0.01, 0.1));
  const MuscleForce s = stretched.Evaluate(1.0, 0.01);
  EXPECT_EQ(s.status, MuscleForceStatus::kEquilibrium);
  EXPECT_FALSE(s.opensim_gives_no_number);
  EXPECT_LT(std::abs(Residual(stretched, MillardSpec(0.01, 0.1), 1.0, s)), 1e-10);
  // "Test exception when muscle cannot be initialized": Thelen l_o = l_Ts = 0.001 m: OpenSim's
  // 20 Newton iterations fail (MuscleCannotEquilibrate). The equilibrium exists (fiber ~2.9
  // l_o, tendon ~1000 times its slack length); isowrench finds it and says OpenSim gives no
  // number there.
  const MuscleForce t = MuscleForceModel("muscle", 1, ThelenSpec(0.001, 0.001)).Evaluate(1, 1);
  EXPECT_EQ(t.status, MuscleForceStatus::kEquilibrium);
  EXPECT_TRUE(t.opensim_gives_no_number);
  EXPECT_NEAR(t.fiber_length / 0.001, 2.88, 0.01);
  EXPECT_LT(std::abs(t.residual), 1e-13 * t.force);
}

TEST(MuscleForce, BarelyTautTendonOfAnUnpennatedThelenMuscle) {
  // Unpennated Thelen2003: the minimum fiber length is 0 (h / sin(phi_max) with h = 0), and
  // OpenSim's first guess, the fiber length of a tendon at 1.01 l_Ts, is 0 when
  // L_MT < 1.01 l_Ts. The fiber of length 0 still has finite forces and slopes.
  const MuscleForceModel m("T", 10.0, ThelenSpec(0.03, 0.02));
  for (double length : {0.02005, 0.0201, 0.0202, 0.021}) {
    const MuscleForce f = m.Evaluate(length, 1.0);
    EXPECT_NE(f.status, MuscleForceStatus::kNoEquilibrium) << length;
    EXPECT_GT(f.force, 0.0) << length;
    if (f.status == MuscleForceStatus::kEquilibrium) {
      EXPECT_LE(std::abs(f.residual), 1e-10) << length;
    }
  }
}

TEST(MuscleForce, NonFiniteOrNonPositiveLengthHasNoEquilibriumAndNoNaN) {
  const MuscleForceModel m("R", 10.0, MillardSpec(0.03, 0.02));
  for (double length : {std::numeric_limits<double>::quiet_NaN(),
                        std::numeric_limits<double>::infinity(), 0.0, -0.01}) {
    const MuscleForce f = m.Evaluate(length, 1.0);
    EXPECT_EQ(f.status, MuscleForceStatus::kNoEquilibrium);
    EXPECT_EQ(f.force, 0.0);
    EXPECT_TRUE(std::isfinite(f.stiffness) && std::isfinite(f.fiber_length));
  }
}

TEST(MuscleForce, OverflowingForceHasNoEquilibriumAndNoInfinity) {
  // Thelen's passive curve exp(KshapePassive (l/l_o - 1) / FmaxMuscleStrain) overflows beyond
  // l/l_o ~ 107 with the defaults: a fiber that long (the rigid-tendon limit of a model with
  // tendon_slack_length 0 and a long path) has no representable force.
  const MuscleForceModel m("T", 1.0, ThelenSpec(0.001, 0.0));
  EXPECT_EQ(m.Evaluate(0.05, 1.0).status, MuscleForceStatus::kEquilibrium);
  const MuscleForce f = m.Evaluate(0.5, 1.0);
  EXPECT_EQ(f.status, MuscleForceStatus::kNoEquilibrium);
  EXPECT_EQ(f.force, 0.0);
  EXPECT_TRUE(f.opensim_gives_no_number);
}

TEST(MuscleForce, FiberLengthSlopeEqualsCentralDifferences) {
  const double h = 1e-7;
  for (const MuscleForceSpec& spec : RatLikeSpecs()) {
    const MuscleForceModel m("R", 10.0, spec);
    const double length = 1.3 * (spec.optimal_fiber_length + spec.tendon_slack_length);
    const MuscleForce f = m.Evaluate(length, 0.5);
    ASSERT_EQ(f.status, MuscleForceStatus::kEquilibrium);
    const double fd =
        (m.Evaluate(length + h, 0.5).fiber_length - m.Evaluate(length - h, 0.5).fiber_length) /
        (2 * h);
    EXPECT_NEAR(f.fiber_length_slope, fd, 1e-6) << spec.optimal_fiber_length;
  }
}

TEST(MuscleForce, ConstantModelIsActivationTimesMaxForce) {
  const MuscleForceModel m("GP", 2.3, MuscleForceSpec{});
  const MuscleForce f = m.Evaluate(0.05, 0.4);
  EXPECT_EQ(f.status, MuscleForceStatus::kEquilibrium);
  EXPECT_DOUBLE_EQ(f.force, 0.4 * 2.3);
  EXPECT_EQ(f.stiffness, 0.0);
  EXPECT_EQ(m.Evaluate(0.05, 0.0).force, 0.0);  // no activation floor
  EXPECT_FALSE(f.opensim_gives_no_number);
}

TEST(MuscleForce, BadInputIsAnErrorNamingMuscleAndValue) {
  const MuscleForceModel m("R_TA", 8.6, MillardSpec(0.0152, 0.0251));
  for (double a : {-0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_THAT([&] { m.Evaluate(0.04, a); },
                ThrowsMessage<Error>(AllOf(HasSubstr("R_TA"), HasSubstr("activation"),
                                           HasSubstr("outside [0, 1]"))));
  }
  auto build = [](MuscleForceSpec spec) { MuscleForceModel("R_TA", 8.6, spec); };
  EXPECT_THAT([&] { build(MillardSpec(0.0, 0.02)); },
              ThrowsMessage<Error>(
                  AllOf(HasSubstr("R_TA"), HasSubstr("optimal_fiber_length 0 m must be > 0"))));
  EXPECT_THAT([&] { build(ThelenSpec(-0.01, 0.02)); },
              ThrowsMessage<Error>(HasSubstr("optimal_fiber_length -0.01 m must be > 0")));
  EXPECT_THAT([&] { build(MillardSpec(0.01, -0.02)); },
              ThrowsMessage<Error>(HasSubstr("tendon_slack_length -0.02 m must be >= 0")));
  EXPECT_THAT([&] { build(MillardSpec(0.01, 0.02, 1.6)); },
              ThrowsMessage<Error>(HasSubstr("pennation_angle_at_optimal 1.6 rad")));
  MuscleForceSpec s = ThelenSpec(0.01, 0.02);
  s.maximum_pennation_angle = 2;
  EXPECT_THAT([&] { build(s); }, ThrowsMessage<Error>(HasSubstr("maximum_pennation_angle 2")));
  s = ThelenSpec(0.01, 0.02);
  s.minimum_activation = 0.005;
  EXPECT_THAT([&] { build(s); },
              ThrowsMessage<Error>(HasSubstr("minimum_activation 0.005 must be >= 0.01")));
  s = MillardSpec(0.01, 0.02);
  s.minimum_activation = 0.005;
  EXPECT_NO_THROW(build(s));  // the damped Millard model accepts it
  s.fiber_damping = 0;
  EXPECT_THAT([&] { build(s); }, ThrowsMessage<Error>(HasSubstr("classic Hill model")));
  s = MillardSpec(0.01, 0.02);
  s.minimum_activation = 1;
  EXPECT_THAT([&] { build(s); }, ThrowsMessage<Error>(HasSubstr("must be in [0, 1)")));
  s = ThelenSpec(0.01, 0.02);
  s.thelen.FmaxTendonStrain = 0;
  EXPECT_THAT([&] { build(s); }, ThrowsMessage<Error>(HasSubstr("FmaxTendonStrain 0 must be > 0")));
  s = ThelenSpec(0.01, 0.02);
  s.thelen.KshapeActive = std::numeric_limits<double>::infinity();
  EXPECT_THAT([&] { build(s); }, ThrowsMessage<Error>(HasSubstr("KshapeActive")));
  EXPECT_THAT([&] { MuscleForceModel("R_TA", 0.0, MillardSpec(0.01, 0.02)); },
              ThrowsMessage<Error>(HasSubstr("max_force 0 N must be > 0")));
  EXPECT_THAT([] { ParseForceModel("hill"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("'hill'"), HasSubstr("millard2012"))));
}

}  // namespace
}  // namespace isowrench
