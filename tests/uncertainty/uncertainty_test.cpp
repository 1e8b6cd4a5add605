// Tests of include/isowrench/uncertainty.hpp against independent references: first-order
// propagation through differences of the engine, analytic percentiles, closed-form Sobol
// indices of an additive model, bit-identical results on any thread count and partition, the
// engine's own dtheta for the small-motion rule, and the bad-input messages.

#include "isowrench/uncertainty.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "input_fixture.hpp"
#include "isowrench/engine.hpp"
#include "isowrench/error.hpp"

namespace isowrench {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::ThrowsMessage;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Model Rat5() {
  return Model::FromUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/rat_hindlimb_5dof.urdf");
}

Eigen::MatrixXd Nominal(const Model& model) {
  Eigen::MatrixXd q = model.nominal_posture();
  return q;
}

TEST(UncertaintySampling, NormalQuantileMatchesErfcToRoundoff) {
  EXPECT_EQ(NormalQuantile(0.5), 0.0);
  EXPECT_NEAR(NormalQuantile(0.975), 1.959963984540054, 1e-15);
  EXPECT_NEAR(NormalQuantile(0.025), -1.959963984540054, 1e-15);
  // Phi(x) = erfc(-x / sqrt 2) / 2, an independent evaluation, over the central region and the
  // two tail regions of AS 241 (the lower tail: 1 - p would round away the upper tail's p).
  for (double x : {-30.0, -8.0, -5.5, -3.0, -1.2, -0.3, 0.1, 0.9, 2.5}) {
    const double p = 0.5 * std::erfc(-x / std::sqrt(2.0));
    EXPECT_NEAR(NormalQuantile(p), x, 1e-13 * std::max(1.0, std::abs(x))) << "x = " << x;
  }
  EXPECT_TRUE(std::isnan(NormalQuantile(0.0)));
  EXPECT_TRUE(std::isnan(NormalQuantile(1.0)));
}

TEST(UncertaintySampling, PhiloxUniformsDependOnlyOnTheCounter) {
  const auto a = PhiloxUniforms(7, 1, 0, 3);
  const auto b = PhiloxUniforms(7, 1, 0, 3);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, PhiloxUniforms(8, 1, 0, 3));
  EXPECT_NE(a, PhiloxUniforms(7, 2, 0, 3));
  // Uniform in (0, 1): the mean and variance of 40,000 draws.
  double s = 0, s2 = 0;
  for (std::uint64_t j = 0; j < 10000; ++j) {
    for (double u : PhiloxUniforms(1, j, 0, 0)) {
      ASSERT_GT(u, 0.0);
      ASSERT_LT(u, 1.0);
      s += u;
      s2 += u * u;
    }
  }
  const double n = 40000, mean = s / n, var = s2 / n - mean * mean;
  EXPECT_NEAR(mean, 0.5, 4 * std::sqrt(1.0 / 12 / n));
  EXPECT_NEAR(var, 1.0 / 12, 0.003);
}

// The engine's reading at perturbed inputs: ln-factors on S_t, angle offsets (rad), a
// misalignment rotation vector (rad). An independent composition through the public API.
Vector6d Reading(const Model& model, const Eigen::VectorXd& q0, const Eigen::VectorXd& x) {
  StiffnessSet s = model.model_stiffness();
  for (int r = 0; r < 6; ++r) s.s_t[r] *= std::exp(x[r]);
  Eigen::VectorXd q = q0;
  q[model.JointIndex("hip_rz")] += x[6];
  q[model.JointIndex("knee_rz")] += x[7];
  Data data(model);
  const WrenchResult w = Evaluate(model, data, q, 0, s);
  const Eigen::Vector3d r = x.segment<3>(8);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (r.norm() > 0) R = Eigen::AngleAxisd(r.norm(), r / r.norm()).toRotationMatrix();
  Vector6d out;
  out.head<3>() = R.transpose() * w.wrench.head<3>();
  out.tail<3>() = R.transpose() * w.wrench.tail<3>();
  return out;
}

TEST(UncertaintyStudy, SmallPerturbationsMatchFirstOrderPropagation) {
  const Model model = Rat5();
  const Eigen::VectorXd q0 = model.nominal_posture();
  // Inputs and their sd in the coordinates of Reading(): ln S_t (6), hip_rz, knee_rz (rad),
  // misalignment (rad).
  Eigen::VectorXd sd(11);
  sd << 0.02, 0.03, 0.02, 0.05, 0.05, 0.04, 0.1 * kDeg, 0.2 * kDeg, 0.1 * kDeg, 0.05 * kDeg,
      0.2 * kDeg;
  UncertaintySpec spec;
  const char* dofs[6] = {"x", "y", "z", "rx", "ry", "rz"};
  for (int r = 0; r < 6; ++r) {
    spec.inputs.push_back(Input(std::string("transducer_stiffness:") + dofs[r],
                                InputDistribution::kLogNormal, {sd[r]}));
  }
  spec.inputs.push_back(Input("angle:hip_rz", InputDistribution::kNormal, {0.1}));
  spec.inputs.push_back(Input("angle:knee_rz", InputDistribution::kNormal, {0.2}));
  spec.inputs.push_back(Input("misalignment", InputDistribution::kNormal, {0.1, 0.05, 0.2}));
  UncertaintyOptions options;
  options.samples = 6000;
  options.sobol = false;
  const UncertaintyResult r = RunUncertainty(model, "GP", Nominal(model), spec, options);
  ASSERT_EQ(r.postures.size(), 1u);
  const PostureUncertainty& p = r.postures[0];
  ASSERT_EQ(p.valid, options.samples);

  // J_p by central differences of the engine, steps of 1e-3 sd (truncation ~1e-6 relative).
  Eigen::MatrixXd Jp(6, 11);
  for (int k = 0; k < 11; ++k) {
    Eigen::VectorXd dx = Eigen::VectorXd::Zero(11);
    dx[k] = 1e-3 * sd[k];
    Jp.col(k) = (Reading(model, q0, dx) - Reading(model, q0, -dx)) / (2 * dx[k]);
  }
  const Eigen::MatrixXd covariance =
      Jp * sd.array().square().matrix().asDiagonal() * Jp.transpose();
  const Vector6d w0 = Reading(model, q0, Eigen::VectorXd::Zero(11));
  const double n = static_cast<double>(p.valid);
  for (int i = 0; i < 6; ++i) {
    const double sd_ref = std::sqrt(covariance(i, i));
    const QuantityStatistics& s = p.statistics[static_cast<size_t>(i)];
    if (sd_ref < 1e-9 * w0.norm()) continue;  // a component the inputs do not move
    // Monte Carlo error of a sd: sd / sqrt(2 n); of a mean: sd / sqrt(n). 5 of each, plus the
    // second-order terms (relative size ~ the input sds, a few percent of a percent here).
    EXPECT_NEAR(s.sd, sd_ref, 5 * sd_ref / std::sqrt(2 * n) + 0.01 * sd_ref) << "component " << i;
    EXPECT_NEAR(s.mean, w0[i], 5 * sd_ref / std::sqrt(n)) << "component " << i;
  }
  // |f|: gradient of the norm, f^T / |f| J_f.
  const Eigen::Vector3d f0 = w0.head<3>();
  const Eigen::RowVectorXd g = f0.transpose() / f0.norm() * Jp.topRows<3>();
  const double sd_norm =
      std::sqrt((g * sd.array().square().matrix().asDiagonal() * g.transpose())(0));
  EXPECT_NEAR(p.statistics[12].sd, sd_norm, 5 * sd_norm / std::sqrt(2 * n) + 0.01 * sd_norm);
  EXPECT_EQ(p.no_equilibrium, 0);
  EXPECT_EQ(p.small_motion_failed, 0);
}

TEST(UncertaintyStudy, OneInputPercentilesAreTheAnalyticOnes) {
  const Model model = Rat5();
  UncertaintySpec spec;
  spec.inputs.push_back(Input("max_force", InputDistribution::kNormal, {0.1}));
  for (bool exact : {true, false}) {
    UncertaintyOptions options;
    options.samples = 20000;
    options.sobol = false;
    options.exact_percentile_values = exact ? 1e9 : 0;
    const UncertaintyResult r = RunUncertainty(model, "GP", Nominal(model), spec, options);
    ASSERT_EQ(r.exact_percentiles, exact);
    const PostureUncertainty& p = r.postures[0];
    // fx = fx0 (1 + 0.1 z): percentile level a at fx0 (1 + 0.1 Phi^-1(a)) (fx0 < 0 flips).
    for (int i : {0, 1, 5}) {
      const double w0 = p.nominal[static_cast<size_t>(i)];
      const double sigma = 0.1 * std::abs(w0);
      const double levels[4] = {0.025, 0.5, 0.95, 0.975};
      for (int k = 0; k < 4; ++k) {
        const double z = NormalQuantile(w0 < 0 ? 1 - levels[k] : levels[k]);
        const double expected = w0 * (1 + 0.1 * z);
        // Sampling sd of a quantile: sqrt(a (1 - a) / n) / phi(z) sigma; histogram: + 0.1 %.
        const double density = std::exp(-0.5 * z * z) / std::sqrt(2 * 3.14159265358979);
        const double tolerance =
            5 * std::sqrt(levels[k] * (1 - levels[k]) / options.samples) / density * sigma +
            (exact ? 0.0 : 1e-3 * std::abs(expected));
        EXPECT_NEAR(p.statistics[static_cast<size_t>(i)].percentiles[static_cast<size_t>(k)],
                    expected, tolerance)
            << "component " << i << " level " << levels[k] << (exact ? " exact" : " histogram");
      }
      EXPECT_NEAR(p.statistics[static_cast<size_t>(i)].sd, sigma,
                  5 * sigma / std::sqrt(2.0 * options.samples));
    }
    // The direction does not change with the force: the angle is 0 up to rounding.
    EXPECT_LT(p.statistics[14].percentiles[3], 1e-7);
    if (!exact) continue;
    // The exact values' histogram of fx: bin k of [lower, upper] holds the values in
    // [lower + k w, lower + (k + 1) w) (the last one up to upper), n P(bin) within 5 binomial sds.
    const QuantityStatistics& fx = p.statistics[0];
    const double w0 = p.nominal[0], n = static_cast<double>(fx.count);
    auto cdf = [&](double x) {  // P(fx <= x), fx = w0 (1 + 0.1 z)
      const double z = (x / w0 - 1.0) / 0.1;
      const double below = 0.5 * std::erfc(-z / std::sqrt(2.0));
      return w0 > 0 ? below : 1.0 - below;
    };
    const int bins = static_cast<int>(fx.histogram.size());
    ASSERT_EQ(bins, kUncertaintyHistogramBins);
    const double width = (fx.histogram_upper - fx.histogram_lower) / bins;
    long total = 0;
    for (int k = 0; k < bins; ++k) {
      const double a = fx.histogram_lower + k * width, b = a + width;
      const double probability = cdf(b) - cdf(a);
      EXPECT_NEAR(static_cast<double>(fx.histogram[static_cast<size_t>(k)]), n * probability,
                  5 * std::sqrt(n * probability * (1 - probability)) + 1)
          << "bin " << k;
      total += fx.histogram[static_cast<size_t>(k)];
    }
    const double inside = cdf(fx.histogram_upper) - cdf(fx.histogram_lower);
    EXPECT_NEAR(static_cast<double>(total), n * inside,
                5 * std::sqrt(n * inside * (1 - inside)) + 1);
  }
}

TEST(UncertaintyStudy, SobolIndicesOfAnAdditiveModelAreTheClosedForm) {
  // The fx reading with independent crosstalk terms and gain is additive and linear in them:
  // fx = g W_fx + sum_k (D_fx / D_k) E_k W_k, so Var = sum_k c_k^2 sd_k^2 and
  // S_k = ST_k = c_k^2 sd_k^2 / Var.
  const Model model = Rat5();
  Data data(model);
  const WrenchResult w = Evaluate(model, data, model.nominal_posture(), 0, model.model_stiffness());
  const double L = model.chain_length();
  UncertaintySpec spec;
  spec.inputs.push_back(Input("gain:fx", InputDistribution::kNormal, {0.05}));
  spec.inputs.push_back(Input("crosstalk:fx_fy", InputDistribution::kNormal, {0.02}));
  spec.inputs.push_back(Input("crosstalk:fx_fz", InputDistribution::kNormal, {0.05}));
  spec.inputs.push_back(Input("crosstalk:fx_mx", InputDistribution::kNormal, {0.1}));
  const double c[4] = {0.05 * w.wrench[0], 0.02 * w.wrench[1], 0.05 * w.wrench[2],
                       0.1 * w.wrench[3] / L};
  double variance = 0;
  for (double v : c) variance += v * v;
  UncertaintyOptions options;
  options.samples = 8192;
  const UncertaintyResult r = RunUncertainty(model, "GP", Nominal(model), spec, options);
  const PostureUncertainty& p = r.postures[0];
  ASSERT_EQ(p.sobol.size(), 4u);
  EXPECT_NEAR(p.statistics[0].sd, std::sqrt(variance), 0.05 * std::sqrt(variance));
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    const double expected = c[k] * c[k] / variance;
    EXPECT_NEAR(p.sobol[static_cast<size_t>(k)][0].first, expected, 0.03) << r.groups[k];
    EXPECT_NEAR(p.sobol[static_cast<size_t>(k)][0].total, expected, 0.03) << r.groups[k];
    sum += p.sobol[static_cast<size_t>(k)][0].first;
  }
  EXPECT_NEAR(sum, 1.0, 0.05);  // additive: the first-order indices add up to 1
  // fy is not read through any of these inputs: no variance, indices 0.
  EXPECT_EQ(p.statistics[1].sd, 0.0);
  EXPECT_EQ(p.sobol[0][1].first, 0.0);
}

std::string ResultBits(const UncertaintyResult& r, const Model& model) {
  UncertaintyResult copy = r;
  copy.seconds = 0;
  std::string bits = UncertaintyJson(copy, model);
  // The JSON prints 17 digits; add the raw bits of every statistic too.
  for (const PostureUncertainty& p : r.postures) {
    for (const QuantityStatistics& s : p.statistics) {
      bits.append(reinterpret_cast<const char*>(&s.mean), sizeof s.mean);
      bits.append(reinterpret_cast<const char*>(&s.sd), sizeof s.sd);
      bits.append(reinterpret_cast<const char*>(s.percentiles.data()), 4 * sizeof(double));
    }
    for (const auto& g : p.sobol) {
      for (const SobolIndex& i : g) {
        bits.append(reinterpret_cast<const char*>(&i.first), sizeof i.first);
        bits.append(reinterpret_cast<const char*>(&i.total), sizeof i.total);
      }
    }
  }
  return bits;
}

TEST(UncertaintyStudy, SameBitsOnAnyThreadCountAndPartition) {
  const Model model = Model(WithBaseStiffness(Rat5().description(), 1e6));
  Eigen::MatrixXd postures(model.dof_count(), 2);
  postures.col(0) = model.nominal_posture();
  postures.col(1) = model.nominal_posture();
  postures(model.JointIndex("knee_rz"), 1) += 20 * kDeg;
  // Batch path with stiffness sets only (kind 0: the sets written directly, the rows' quantities
  // four at a time), batch path with the reading (kind 1) and scalar path (kind 2: angles too).
  // Under the sanitizers (which check memory, not numbers) kinds 0 and 2 on 4 threads only.
#if defined(__SANITIZE_ADDRESS__) || defined(ISOWRENCH_TEST_SANITIZED)
  const std::vector<int> kinds = {0, 2}, thread_counts = {4};
#else
  const std::vector<int> kinds = {0, 1, 2}, thread_counts = {2, 4};
#endif
  for (int kind : kinds) {
    const bool angles = kind == 2;
    for (bool exact : {true, false}) {
      UncertaintySpec spec;
      spec.inputs.push_back(Input("transducer_stiffness:rz", InputDistribution::kLogNormal, {0.5}));
      spec.inputs.push_back(Input("base_stiffness", InputDistribution::kLogUniform, {}, 1e4, 1e7));
      if (kind >= 1)
        spec.inputs.push_back(Input("misalignment", InputDistribution::kNormal, {1.0}));
      if (angles) spec.inputs.push_back(Input("angle:hip_rz", InputDistribution::kNormal, {2.0}));
      UncertaintyOptions options;
      options.samples = 2 * kUncertaintyBlockSamples + 50;  // 3 blocks, the last one short
      options.exact_percentile_values = exact ? 1e9 : 0;
      options.threads = 1;
      const UncertaintyResult one = RunUncertainty(model, "GP", postures, spec, options);
      const std::string reference = ResultBits(one, model);
      for (int threads : thread_counts) {
        options.threads = threads;
        EXPECT_EQ(ResultBits(RunUncertainty(model, "GP", postures, spec, options), model),
                  reference)
            << threads << " threads, kind " << kind << ", exact " << exact;
      }
      // Parts [2, 3), [0, 1), [1, 2), through bytes, in that order, on 2 threads each.
      const UncertaintyStudy study(model, "GP", postures, spec, options);
      ASSERT_EQ(study.block_count(), 3);
      std::vector<UncertaintyPartial> parts;
      for (auto [a, b] : {std::pair<long, long>{2, 3}, {0, 1}, {1, 2}}) {
        parts.push_back(
            UncertaintyPartial::FromBytes(RunUncertaintyBlocks(study, a, b, 2).ToBytes()));
      }
      UncertaintyResult merged = FinishUncertainty(study, parts);
      EXPECT_EQ(ResultBits(merged, model), reference) << "kind " << kind << ", exact " << exact;
      if (angles || exact) continue;
      // A missing block, a block twice, another study's partial: errors.
      parts.pop_back();
      EXPECT_THAT([&] { FinishUncertainty(study, parts); },
                  ThrowsMessage<Error>(HasSubstr("blocks 1-2 are missing")));
      parts.push_back(parts[0]);
      parts.push_back(RunUncertaintyBlocks(study, 1, 2));
      EXPECT_THAT([&] { FinishUncertainty(study, parts); },
                  ThrowsMessage<Error>(HasSubstr("is in two partials")));
      UncertaintyOptions other = options;
      other.seed = 2;
      const UncertaintyStudy foreign(model, "GP", postures, spec, other);
      EXPECT_THAT([&] { FinishUncertainty(study, {RunUncertaintyBlocks(foreign, 0, 3)}); },
                  ThrowsMessage<Error>(HasSubstr("of another study")));
    }
  }
}

TEST(UncertaintyStudy, StiffnessRowsWrittenDirectlyEqualTheGeneralPath) {
  // Stiffness, force and activation inputs alone take the direct path (the rows' stiffness
  // sets written entry by entry, the draws dimension by dimension); a misalignment of sd 0
  // (R = I: the reading is W) sends the same draws through RowInputs. Both must give the same
  // numbers for the common inputs (the uniforms depend on the sample and dimension only).
  const Model model = Model(WithBaseStiffness(Rat5().description(), 1e6));
  Eigen::MatrixXd postures(model.dof_count(), 2);
  postures.col(0) = model.nominal_posture();
  postures.col(1) = model.nominal_posture();
  postures(model.JointIndex("knee_rz"), 1) += 20 * kDeg;
  UncertaintySpec direct;
  direct.inputs.push_back(Input("transducer_stiffness:x", InputDistribution::kLogNormal, {0.4}));
  direct.inputs.push_back(Input("transducer_stiffness:rz", InputDistribution::kLogNormal, {0.6}));
  direct.inputs.push_back(Input("base_stiffness", InputDistribution::kLogUniform, {}, 1e4, 1e7));
  direct.inputs.push_back(Input("max_force", InputDistribution::kNormal, {0.2}));
  direct.inputs.push_back(Input("activation", InputDistribution::kUniform, {}, 0.5, 1.0));
  UncertaintySpec general = direct;
  general.inputs.push_back(Input("misalignment", InputDistribution::kNormal, {0.0}));
  for (bool sobol : {true, false}) {
    UncertaintyOptions options;
    options.samples = 2 * kUncertaintyBlockSamples + 37;  // 3 blocks, the last one short
    options.sobol = sobol;
    const UncertaintyResult a = RunUncertainty(model, "GP", postures, direct, options);
    const UncertaintyResult b = RunUncertainty(model, "GP", postures, general, options);
    ASSERT_EQ(a.postures.size(), b.postures.size());
    for (size_t p = 0; p < a.postures.size(); ++p) {
      const PostureUncertainty &x = a.postures[p], &y = b.postures[p];
      EXPECT_EQ(x.valid, y.valid);
      EXPECT_EQ(x.small_motion_failed, y.small_motion_failed);
      EXPECT_EQ(x.sobol_rows, y.sobol_rows);
      for (int q = 0; q < kUncertaintyQuantities; ++q) {
        const QuantityStatistics &s = x.statistics[static_cast<size_t>(q)],
                                 &t = y.statistics[static_cast<size_t>(q)];
        EXPECT_EQ(s.count, t.count) << q;
        EXPECT_EQ(s.mean, t.mean) << q;
        EXPECT_EQ(s.sd, t.sd) << q;
        EXPECT_EQ(s.percentiles, t.percentiles) << q;
        EXPECT_EQ(s.histogram, t.histogram) << q;
        for (size_t g = 0; g < x.sobol.size(); ++g) {
          EXPECT_EQ(x.sobol[g][static_cast<size_t>(q)].first,
                    y.sobol[g][static_cast<size_t>(q)].first)
              << q << " " << g;
          EXPECT_EQ(x.sobol[g][static_cast<size_t>(q)].total,
                    y.sobol[g][static_cast<size_t>(q)].total)
              << q << " " << g;
        }
      }
      // The inputs matter: the indices are not all zero.
      if (sobol) {
        EXPECT_GT(x.sobol[2][0].first, 0.05);
      }
    }
  }
}

TEST(UncertaintyStudy, SmallMotionFromTheWrenchEqualsTheEnginesDtheta) {
  // Stiffness-only studies take dtheta from W (batch path); with an angle input of sd 0 the
  // same draws go through the scalar path, which reads the engine's dtheta. Soft transducers
  // (a log-uniform over 4 decades) make some samples fail the small-motion rule.
  const Model model = Model(WithBaseStiffness(Rat5().description(), 1e5));
  UncertaintySpec spec;
  spec.inputs.push_back(
      Input("transducer_stiffness:x", InputDistribution::kLogUniform, {}, 1, 1e6));
  spec.inputs.push_back(
      Input("transducer_stiffness:rz", InputDistribution::kLogUniform, {}, 1e-3, 1e3));
  spec.inputs.push_back(Input("base_stiffness", InputDistribution::kLogNormal, {1.0}));
  UncertaintyOptions options;
  options.samples = 3000;
  options.sobol = false;
  const UncertaintyResult batch = RunUncertainty(model, "GP", Nominal(model), spec, options);
  spec.inputs.push_back(Input("angle:hip_rz", InputDistribution::kNormal, {0.0}));
  const UncertaintyResult scalar = RunUncertainty(model, "GP", Nominal(model), spec, options);
  const PostureUncertainty &a = batch.postures[0], &b = scalar.postures[0];
  EXPECT_GT(a.small_motion_failed, 100);
  EXPECT_LT(a.small_motion_failed, options.samples - 100);
  EXPECT_EQ(a.small_motion_failed, b.small_motion_failed);
  EXPECT_EQ(a.valid, b.valid);
  for (int q = 0; q < 6; ++q) {
    EXPECT_NEAR(a.statistics[static_cast<size_t>(q)].mean,
                b.statistics[static_cast<size_t>(q)].mean,
                1e-9 * b.statistics[static_cast<size_t>(q)].sd + 1e-15);
  }
}

TEST(UncertaintyStudy, NoEquilibriumIsCountedAndNeverAStatistic) {
  // planar_4r without joint stiffness has a self-motion the muscle drives: every sample is
  // without equilibrium, and nothing reaches a statistic.
  LimbDescription d = ReadUrdfFile(std::string(ISOWRENCH_TEST_URDF_DIR) + "/planar_4r.urdf");
  for (JointSpec& j : d.joints) j.stiffness = 0.0;
  d.coordinates.clear();
  const Model model(d);
  UncertaintySpec spec;
  spec.inputs.push_back(Input("transducer_stiffness:x", InputDistribution::kLogNormal, {0.1}));
  UncertaintyOptions options;
  options.samples = 500;
  const UncertaintyResult r =
      RunUncertainty(model, model.muscle(0).name, Nominal(model), spec, options);
  const PostureUncertainty& p = r.postures[0];
  EXPECT_EQ(p.no_equilibrium, p.samples);
  EXPECT_EQ(p.valid, 0);
  for (const QuantityStatistics& s : p.statistics) EXPECT_EQ(s.count, 0);
  const std::string json = UncertaintyJson(r, model);
  EXPECT_THAT(json, Not(HasSubstr("NaN")));
  EXPECT_THAT(json, HasSubstr("\"no_equilibrium\": 1.0"));
}

TEST(UncertaintyStudy, BadInputIsAnErrorNamingIt) {
  const Model model = Rat5();
  auto run = [&](const UncertainInput& in) {
    UncertaintySpec spec;
    spec.inputs.push_back(in);
    UncertaintyStudy study(model, "GP", Nominal(model), spec, UncertaintyOptions{});
  };
  EXPECT_THAT([&] { run(Input("transducer_stifness:x", InputDistribution::kLogNormal, {1})); },
              ThrowsMessage<Error>(HasSubstr("did you mean 'transducer_stiffness'")));
  EXPECT_THAT([&] { run(Input("angle:hip_q", InputDistribution::kNormal, {1})); },
              ThrowsMessage<Error>(HasSubstr("did you mean 'hip_rz'")));
  EXPECT_THAT([&] { run(Input("angle:hip_rz", InputDistribution::kNormal, {-1})); },
              ThrowsMessage<Error>(HasSubstr("sd -1 must be finite and >= 0")));
  EXPECT_THAT(
      [&] { run(Input("transducer_stiffness:x", InputDistribution::kLogUniform, {}, 1e6, 1e6)); },
      ThrowsMessage<Error>(HasSubstr("empty support")));
  EXPECT_THAT([&] { run(Input("max_force", InputDistribution::kUniform, {}, 2, 1)); },
              ThrowsMessage<Error>(HasSubstr("empty support [2, 1]")));
  EXPECT_THAT([&] { run(Input("joint_stiffness:hip_rz", InputDistribution::kLogNormal, {1})); },
              ThrowsMessage<Error>(HasSubstr("the model's value is 0")));
  EXPECT_THAT([&] { run(Input("base_stiffness", InputDistribution::kLogNormal, {1})); },
              ThrowsMessage<Error>(HasSubstr("has no base dofs")));
  EXPECT_THAT([&] { run(Input("point:GQ:1", InputDistribution::kNormal, {1})); },
              ThrowsMessage<Error>(HasSubstr("unknown muscle 'GQ' (did you mean 'GP'?)")));
  EXPECT_THAT(
      [&] { ParseUncertaintySpec(R"({"inputs": [{"name": "gain:fx", "sdd": 1}]})", "s.json"); },
      ThrowsMessage<Error>(HasSubstr("s.json: inputs[0].sdd: unknown field (did you mean 'sd'?)")));
  // A fit of another model.
  const std::string path = ::testing::TempDir() + "/other_fit.json";
  {
    std::ofstream out(path);
    out << R"({"model": "planar_2r", "chosen": []})";
  }
  EXPECT_THAT(
      [&] { ReadFitUncertainty(path, model); },
      ThrowsMessage<Error>(HasSubstr("is a fit of model 'planar_2r', not of 'rat_hindlimb_5dof'")));
  std::remove(path.c_str());
}

TEST(UncertaintyStudy, FromFitSamplesTheParametersWithTheirCorrelation) {
  // force_scale:GP (log10 SE 0.01) and gain:fx (log10 SE 0.005), correlation 0.5: ln fx moves
  // by ln 10 (x1 + x2), so sd(fx) = |fx0| ln 10 sqrt(s1^2 + s2^2 + 2 r s1 s2) to first order,
  // and fy by ln 10 x1 alone.
  const Model model = Rat5();
  const std::string path = ::testing::TempDir() + "/rat_fit.json";
  {
    std::ofstream out(path);
    out << R"({"model": "rat_hindlimb_5dof", "chosen": [
      {"effect": "force_scale:GP", "parameters": [{"name": "scale", "value": 0.9,
        "standard_error": 0.0207, "log10_standard_error": 0.01, "unit": "x"}]},
      {"effect": "gain:fx", "parameters": [{"name": "factor", "value": 1.02,
        "standard_error": 0.0117, "log10_standard_error": 0.005, "unit": "x"}]}],
      "correlations": {"parameters": ["force_scale:GP.scale", "gain:fx.factor"],
                       "matrix": [[1, 0.5], [0.5, 1]]}})";
  }
  UncertaintySpec spec;
  spec.has_fit = true;
  spec.fit = ReadFitUncertainty(path, model);
  std::remove(path.c_str());
  ASSERT_EQ(spec.fit.names, (std::vector<std::string>{"force_scale:GP.scale", "gain:fx.factor"}));
  UncertaintyOptions options;
  options.samples = 8000;
  const UncertaintyResult r = RunUncertainty(model, "GP", Nominal(model), spec, options);
  ASSERT_EQ(r.groups, std::vector<std::string>{"fit"});
  const PostureUncertainty& p = r.postures[0];
  Data data(model);
  const Vector6d w =
      Evaluate(model, data, model.nominal_posture(), 0, model.model_stiffness()).wrench;
  const double ln10 = std::log(10.0), s1 = 0.01, s2 = 0.005;
  EXPECT_NEAR(p.nominal[0], w[0] * 0.9 * 1.02, 1e-12 * std::abs(w[0]));
  const double sd_fx = std::abs(w[0]) * 0.9 * 1.02 * ln10 * std::sqrt(s1 * s1 + s2 * s2 + s1 * s2);
  const double sd_fy = std::abs(w[1]) * 0.9 * ln10 * s1;
  const double n = 2.0 * options.samples;
  EXPECT_NEAR(p.statistics[0].sd, sd_fx, 5 * sd_fx / std::sqrt(2 * n) + 0.01 * sd_fx);
  EXPECT_NEAR(p.statistics[1].sd, sd_fy, 5 * sd_fy / std::sqrt(2 * n) + 0.01 * sd_fy);
  EXPECT_NEAR(p.statistics[0].percentiles[1], p.nominal[0], 5 * sd_fx / std::sqrt(n));
  // One group: its first-order index is the whole variance.
  EXPECT_NEAR(p.sobol[0][0].first, 1.0, 0.03);
}

TEST(UncertaintyStudy, SpecFileParsesEveryField) {
  const UncertaintySpec spec = ParseUncertaintySpec(R"({
    "comment": "a lab's inputs",
    "inputs": [
      {"name": "transducer_stiffness:x", "distribution": "lognormal", "sd": 0.35},
      {"name": "misalignment", "sd": [1, 1, 2]},
      {"name": "base_stiffness", "distribution": "loguniform", "lower": 1e4, "upper": 1e7},
      {"name": "max_force", "lower": 0.8, "upper": 1.2}
    ]})",
                                                    "spec.json");
  ASSERT_EQ(spec.inputs.size(), 4u);
  EXPECT_EQ(spec.inputs[0].distribution, InputDistribution::kLogNormal);
  EXPECT_EQ(spec.inputs[1].distribution, InputDistribution::kNormal);
  EXPECT_EQ(spec.inputs[1].sd, (std::vector<double>{1, 1, 2}));
  EXPECT_EQ(spec.inputs[2].distribution, InputDistribution::kLogUniform);
  EXPECT_EQ(spec.inputs[2].upper, 1e7);
  EXPECT_EQ(spec.inputs[3].distribution, InputDistribution::kUniform);
}

}  // namespace
}  // namespace isowrench
