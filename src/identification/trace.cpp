// The trace of an unexplained residual: where the remaining weighted residual lives. Probes that
// name a variable (a stiffness or an offset at each coordinate, each muscle's force and path),
// smooth trends (trial order, coordinates, muscle lengths) and the share per muscle and axis.
// What the trace cannot evaluate is counted and reported as a note, never skipped silently.

#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <numeric>

#include "identification/fit_stages.hpp"
#include "isowrench/error.hpp"
#include "util/text.hpp"

namespace isowrench::ident {
namespace {

/// What the trace could not evaluate, per kind: how many of how many, and the first reason.
/// Each kind with a count becomes one note of the report ("trace: ...").
class TraceSkips {
 public:
  void Add(const std::string& what, long count, long of, const std::string& why) {
    if (count > 0) entries_.push_back({what, count, of, why});
  }
  void AddTo(FitReport* report) const {
    for (const Entry& e : entries_) {
      report->notes.push_back("trace: " + std::to_string(e.count) + " of " + std::to_string(e.of) +
                              " " + e.what + (e.why.empty() ? "" : " (first: " + e.why + ")"));
    }
  }

 private:
  struct Entry {
    std::string what;
    long count = 0, of = 0;
    std::string why;
  };
  std::vector<Entry> entries_;
};

/// The weighted residual the trace explains (outlier rows left out).
struct TraceResidual {
  std::vector<bool> use;                          ///< not an outlier row
  std::vector<Eigen::Matrix<double, 6, 1>> rows;  ///< weighted residual per trial
  double total = 0.0;                             ///< its squared norm over the used rows
  Eigen::VectorXd stacked;                        ///< the rows stacked (unused rows zero)
  int used = 0;
};

TraceResidual MakeTraceResidual(const std::vector<Trial>& trials, const Current& current,
                                const FitOptions& options, const FitReport& report) {
  TraceResidual t;
  t.use.assign(trials.size(), true);
  for (size_t k = 0; k < trials.size(); ++k) {
    t.use[k] = std::find(report.outlier_rows.begin(), report.outlier_rows.end(), trials[k].line) ==
               report.outlier_rows.end();
  }
  t.rows.resize(trials.size());
  for (size_t k = 0; k < trials.size(); ++k) {
    for (int c = 0; c < 6; ++c) {
      t.rows[k][c] =
          Weight(trials[k], c, options) * (trials[k].wrench[c] - current.prediction[k][c]);
    }
    if (t.use[k]) t.total += t.rows[k].squaredNorm();
  }
  t.stacked = Eigen::VectorXd::Zero(6 * trials.size());
  for (size_t k = 0; k < trials.size(); ++k) {
    if (!t.use[k]) continue;
    t.stacked.segment<6>(6 * k) = t.rows[k];
    ++t.used;
  }
  return t;
}

/// Share of the weighted residual explained by a quadratic in x (per component, summed).
double QuadraticShare(const std::vector<Eigen::Matrix<double, 6, 1>>& r,
                      const std::vector<double>& x, const std::vector<bool>& use, double total) {
  std::vector<int> rows;
  for (size_t k = 0; k < x.size(); ++k) {
    if (use[k] && std::isfinite(x[k])) rows.push_back(static_cast<int>(k));
  }
  if (rows.size() < 8 || !(total > 0)) return 0.0;
  double mean = 0, sd = 0;
  for (int k : rows) mean += x[k];
  mean /= rows.size();
  for (int k : rows) sd += std::pow(x[k] - mean, 2);
  sd = std::sqrt(sd / rows.size());
  if (!(sd > 0)) return 0.0;
  Eigen::MatrixXd A(rows.size(), 3);
  Eigen::MatrixXd B(rows.size(), 6);
  for (size_t i = 0; i < rows.size(); ++i) {
    const double z = (x[rows[i]] - mean) / sd;
    A.row(i) << 1.0, z, z * z;
    B.row(i) = r[rows[i]].transpose();
  }
  Eigen::MatrixXd coef = A.colPivHouseholderQr().solve(B);
  Eigen::MatrixXd fitted = A * coef;
  // Explained beyond the constant (a constant is the sensor offset, not a trend).
  Eigen::RowVectorXd means = B.colwise().mean();
  double explained = 0;
  for (int c = 0; c < 6; ++c) explained += (fitted.col(c).array() - means[c]).square().sum();
  return explained / total;
}

/// Trends: the share explained by a quadratic in trial order, in each limb coordinate and in
/// each muscle's length (at the trial's posture).
void AddTrends(const Model& nominal, const std::vector<Trial>& trials, const TraceResidual& res,
               std::vector<FitReport::TraceItem>* items, TraceSkips* skips) {
  std::vector<double> order(trials.size());
  for (size_t k = 0; k < trials.size(); ++k) order[k] = static_cast<double>(k);
  items->push_back({"trial order", QuadraticShare(res.rows, order, res.use, res.total),
                    "drift over the session"});
  TrialMapper mapper(nominal);
  std::vector<Eigen::VectorXd> q(trials.size());
  long unmapped = 0;
  std::string unmapped_why;
  for (size_t k = 0; k < trials.size(); ++k) {
    try {
      mapper.Map(trials[k], &q[k]);
    } catch (const Error& e) {
      // NaN: QuadraticShare leaves the trial out of every coordinate trend.
      q[k] =
          Eigen::VectorXd::Constant(nominal.dof_count(), std::numeric_limits<double>::quiet_NaN());
      if (unmapped++ == 0) unmapped_why = e.what();
    }
  }
  skips->Add(
      "trials left out of the coordinate trends (the posture cannot be mapped onto the "
      "model)",
      unmapped, static_cast<long>(trials.size()), unmapped_why);
  for (int j = 0; j < nominal.dof_count(); ++j) {
    if (nominal.joint(j).role != JointRole::kLimb) continue;
    std::vector<double> x(trials.size());
    for (size_t k = 0; k < trials.size(); ++k) x[k] = q[k][j];
    items->push_back(
        {"coordinate " + nominal.joint_names()[j], QuadraticShare(res.rows, x, res.use, res.total),
         "a trend with this coordinate (joint_offset, a stiffness or a path outside the library)"});
  }
  for (int m = 0; m < nominal.muscle_count(); ++m) {
    const std::string& name = nominal.muscle(m).name;
    std::string why;
    const std::vector<double> lengths = MuscleLengths(nominal, name, trials, &why);
    long missing = 0;
    for (double l : lengths) missing += std::isfinite(l) ? 0 : 1;
    skips->Add("trials left out of the length trend of " + name +
                   " (the muscle length cannot be evaluated there)",
               missing, static_cast<long>(trials.size()), why);
    items->push_back({"length of " + name, QuadraticShare(res.rows, lengths, res.use, res.total),
                      "a trend with the muscle's length (force-length behaviour outside the "
                      "model)"});
  }
}

/// A probe: a variable and the perturbed models whose prediction changes span its first-order
/// effect.
struct Probe {
  std::string variable, note;
  std::vector<AugmentedModel> models;
  /// Optional per-trial multipliers: each model's column is repeated once per multiplier with
  /// trial k's rows scaled by it (a force that follows a variable: 1, z, z^2).
  std::vector<std::vector<double>> multipliers = {};
};

/// The probes that name a variable directly: a small stiffness and an offset at each limb
/// coordinate, each muscle's force, its force-length parameters (a muscle with a force model),
/// its force following its length (a quadratic: force-length behaviour outside the model) and
/// its path points (three directions per point).
std::vector<Probe> MakeProbes(const Model& nominal, const std::vector<Trial>& trials,
                              const AugmentedModel& at, TraceSkips* skips) {
  std::vector<Probe> probes;
  long limb = 0, no_stiffness = 0;
  std::string stiffness_why;
  for (int j = 0; j < nominal.dof_count(); ++j) {
    if (nominal.joint(j).role != JointRole::kLimb) continue;
    ++limb;
    const std::string& name = nominal.joint_names()[j];
    Probe stiffness{"stiffness at " + name,
                    "a passive stiffness of this coordinate outside the model and the library",
                    {}};
    try {
      // A stiffness small against what the transducer opposes to this coordinate (j^T S_t j):
      // the wrench changes linearly with it.
      const Eigen::VectorXd jc = NominalJacobianColumn(nominal, name);
      const double scale = jc.dot(nominal.transducer().stiffness.asDiagonal() * jc);
      const double k0 = FindCoordinate(at.description, name).stiffness;
      AugmentedModel m = at;
      m.description = WithJointStiffness(
          at.description, name, k0 + 1e-4 * (std::isfinite(scale) && scale > 0 ? scale : 1.0));
      stiffness.models.push_back(std::move(m));
    } catch (const Error& e) {
      // The probe keeps no model: it has no column and is not listed.
      if (no_stiffness++ == 0) stiffness_why = name + ": " + e.what();
    }
    probes.push_back(std::move(stiffness));
    Probe offset{"offset of " + name, "the recorded angle of this coordinate is off", {}};
    AugmentedModel m = at;
    m.posture_offset[name] +=
        nominal.joint(j).type == JointType::kPrismatic ? 1e-5 : 1e-4;  // m or rad
    offset.models.push_back(std::move(m));
    probes.push_back(std::move(offset));
  }
  skips->Add("stiffness probes not evaluated (the probe model cannot be built)", no_stiffness, limb,
             stiffness_why);
  for (size_t i = 0; i < at.description.muscles.size(); ++i) {
    const MuscleSpec& muscle = at.description.muscles[i];
    Probe force{"force of " + muscle.name,
                "this muscle's force differs from the model (max force, force-length)",
                {}};
    AugmentedModel m = at;
    m.description.muscles[i].max_force *= 1.001;
    force.models.push_back(m);
    probes.push_back(std::move(force));
    // A muscle with a force model: its force-length operating point (the force_length effect's
    // parameters). Each length is stepped by -10 % and +10 %: the two secants span the first-
    // and second-order change, so a curve off by 10-20 % (not only an infinitesimal shift) is
    // explained.
    if (muscle.force.model != ForceModelType::kConstant) {
      Probe curve{"force-length of " + muscle.name + " (force_length:" + muscle.name + ")",
                  "this muscle's optimal fiber length or tendon slack length differs from its "
                  "force model (fit with --candidates force_length:" +
                      muscle.name + ")",
                  {}};
      for (double factor : {0.9, 1.1}) {
        AugmentedModel fiber = at;
        fiber.description.muscles[i].force.optimal_fiber_length *= factor;
        curve.models.push_back(std::move(fiber));
        if (muscle.force.tendon_slack_length > 0) {
          AugmentedModel tendon = at;
          tendon.description.muscles[i].force.tendon_slack_length *= factor;
          curve.models.push_back(std::move(tendon));
        }
      }
      probes.push_back(std::move(curve));
    }
    // The muscle's force as a quadratic in its length (standardised over its trials): what a
    // force-length curve outside the model leaves, and what per-trial factors would absorb.
    Probe length{"force of " + muscle.name + " following its length",
                 "this muscle's force changes with its length (force-length behaviour outside "
                 "the model and the library)",
                 {std::move(m)},
                 {}};
    std::vector<double> l = MuscleLengths(nominal, muscle.name, trials);
    double mean = 0, spread = 0;
    int count = 0;
    for (size_t k = 0; k < l.size(); ++k) {
      if (trials[k].muscle != muscle.name || !std::isfinite(l[k])) continue;
      mean += l[k];
      ++count;
    }
    mean /= std::max(1, count);
    for (size_t k = 0; k < l.size(); ++k) {
      if (trials[k].muscle == muscle.name && std::isfinite(l[k]))
        spread += std::pow(l[k] - mean, 2);
    }
    spread = std::sqrt(spread / std::max(1, count));
    if (count >= 8 && spread > 0) {
      length.multipliers.assign(3, std::vector<double>(trials.size(), 0.0));
      for (size_t k = 0; k < l.size(); ++k) {
        if (!std::isfinite(l[k])) continue;  // left out (counted in the length trend's note)
        const double z = (l[k] - mean) / spread;
        length.multipliers[0][k] = 1.0;
        length.multipliers[1][k] = z;
        length.multipliers[2][k] = z * z;
      }
      probes.push_back(std::move(length));
    }
    Probe path{"path of " + muscle.name,
               "this muscle's path points (moment arms) differ from the model",
               {}};
    for (size_t p = 0; p < muscle.path.size(); ++p) {
      for (int axis = 0; axis < 3; ++axis) {
        AugmentedModel shifted = at;
        shifted.description.muscles[i].path[p].position[axis] += 1e-5;  // m
        path.models.push_back(std::move(shifted));
      }
    }
    probes.push_back(std::move(path));
  }
  return probes;
}

/// Columns a probe or a tentative effect could not contribute: why the first was lost.
struct ColumnLoss {
  long columns = 0;
  std::string why;
  void Add(const std::string& reason) {
    if (columns++ == 0) why = reason;
  }
};

/// Whitened prediction changes of a set of perturbed models (outlier rows zero). A model that
/// cannot predict the trials leaves its column zero (counted in `loss`); rows it cannot predict
/// stay zero too.
Eigen::MatrixXd ProbeColumns(const std::vector<AugmentedModel>& models,
                             const std::vector<Trial>& trials, const Current& current,
                             const TraceResidual& res, const FitOptions& options,
                             ColumnLoss* loss) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(6 * trials.size(), models.size());
  for (size_t c = 0; c < models.size(); ++c) {
    Prediction p;
    try {
      p = PredictTrials(models[c], trials);
    } catch (const Error& e) {
      loss->Add(e.what());
      continue;
    }
    if (p.failed > 0) loss->Add(p.message);
    for (size_t k = 0; k < trials.size(); ++k) {
      if (!res.use[k] || !p.ok[k]) continue;
      for (int m = 0; m < 6; ++m) {
        D(6 * k + m, c) =
            Weight(trials[k], m, options) * (p.wrench[k][m] - current.prediction[k][m]);
      }
    }
  }
  if (!D.allFinite()) {
    loss->Add("a prediction change is not finite: every column of this probe set to zero");
    D.setZero();
  }
  return D;
}

/// Orthonormal basis of the tentative effects' columns: they stay in the model and would be
/// refitted with the missing variable, so what a probe explains is measured orthogonally to
/// them (a score test), and a variable they partly absorbed is still found.
Eigen::MatrixXd TentativeBasis(const Model& nominal, const std::vector<Trial>& trials,
                               const Current& current, const TraceResidual& res,
                               const FitOptions& options, TraceSkips* skips) {
  std::vector<AugmentedModel> chosen_models;
  long parameters = 0;
  ColumnLoss unbuilt;
  for (size_t e = 0; e < current.effects.size(); ++e) {
    const AppliedEffect& a = current.effects[e];
    if (a.effect.per_trial) continue;
    for (size_t j = 0; j < a.values.size(); ++j) {
      ++parameters;
      const EffectParameter& q = a.effect.parameters[j];
      std::vector<AppliedEffect> stepped = current.effects;
      const double step = 1e-3 * (ToInternal(q, q.upper) - ToInternal(q, q.lower));
      stepped[e].values[j] = ToUser(q, ToInternal(q, a.values[j]) + step);
      try {
        chosen_models.push_back(ApplyEffects(nominal.description(), stepped));
      } catch (const Error& err) {
        unbuilt.Add(a.effect.id + "." + q.name + ": " + err.what());
      }
    }
  }
  skips->Add(
      "parameters of the tentative effects not projected out of the probes (the stepped "
      "model cannot be built)",
      unbuilt.columns, parameters, unbuilt.why);
  Eigen::MatrixXd Q(6 * trials.size(), 0);
  if (chosen_models.empty()) return Q;
  ColumnLoss lost;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(
      ProbeColumns(chosen_models, trials, current, res, options, &lost));
  skips->Add(
      "columns of the tentative effects incomplete (the stepped model cannot predict "
      "every trial: those rows count as zero)",
      lost.columns, static_cast<long>(chosen_models.size()), lost.why);
  if (qr.rank() > 0)
    Q = qr.householderQ() * Eigen::MatrixXd::Identity(6 * trials.size(), qr.rank());
  return Q;
}

/// Order the items: trends and probes by their share beyond what as many random directions
/// would explain in pure noise (`chance` columns each), then the muscle/axis shares by share;
/// keep those above kTraceMinShare and write the summary.
void ListTrace(const std::vector<Trial>& trials, const TraceResidual& res,
               std::vector<FitReport::TraceItem> items, const std::vector<double>& chance,
               FitReport* report) {
  {
    std::vector<size_t> rank(items.size());
    std::iota(rank.begin(), rank.end(), size_t{0});
    const double n = std::max(1, 6 * res.used);
    std::stable_sort(rank.begin(), rank.end(), [&](size_t a, size_t b) {
      return items[a].share - chance[a] / n > items[b].share - chance[b] / n;
    });
    std::vector<FitReport::TraceItem> sorted;
    for (size_t i : rank) sorted.push_back(items[i]);
    items = std::move(sorted);
  }
  const size_t trends = items.size();
  // Per muscle and axis: share of the residual in the trials of each muscle, per component.
  const char* axes[6] = {"fx", "fy", "fz", "mx", "my", "mz"};
  std::map<std::string, Vector6d> per_muscle;
  for (size_t k = 0; k < trials.size(); ++k) {
    if (!res.use[k]) continue;
    Vector6d& s = per_muscle.emplace(trials[k].muscle, Vector6d::Zero()).first->second;
    s += res.rows[k].cwiseAbs2();
  }
  for (const auto& m : per_muscle) {
    for (int c = 0; c < 6; ++c) {
      items.push_back({"muscle " + m.first + " axis " + axes[c],
                       res.total > 0 ? m.second[c] / res.total : 0.0,
                       "share of the residual in this muscle's trials on this axis"});
    }
  }
  std::stable_sort(items.begin() + trends, items.end(),
                   [](const FitReport::TraceItem& a, const FitReport::TraceItem& b) {
                     return a.share > b.share;
                   });
  std::vector<std::string> top_trends, top_axes;
  for (size_t k = 0; k < items.size(); ++k) {
    const FitReport::TraceItem& i = items[k];
    if (!(i.share >= kTraceMinShare) || !std::isfinite(i.share)) continue;
    report->trace.push_back(i);
    std::vector<std::string>& top = k < trends ? top_trends : top_axes;
    if (top.size() < 2)
      top.push_back(i.variable + " (" + util::FormatNumber(100 * i.share, 3) + " %)");
  }
  if (!top_trends.empty()) report->trace_summary = "it follows " + util::Join(top_trends, ", ");
  if (!top_axes.empty()) {
    report->trace_summary += (report->trace_summary.empty() ? "it sits in " : "; it sits in ") +
                             util::Join(top_axes, ", ");
  }
  if (!report->closest_rejected.empty()) {
    report->trace_summary += (report->trace_summary.empty() ? "" : "; ") +
                             std::string("closest rejected candidate: ") + report->closest_rejected;
  }
}

}  // namespace

void ReportTrace(const Model& nominal, const std::vector<Trial>& trials, const Current& current,
                 const FitOptions& options, FitReport* report) {
  const TraceResidual res = MakeTraceResidual(trials, current, options, *report);
  TraceSkips skips;
  std::vector<FitReport::TraceItem> items;
  AddTrends(nominal, trials, res, &items, &skips);
  std::vector<double> chance(items.size(), 2.0 * 6.0);  // columns of each quadratic trend
  const std::vector<Probe> probes = MakeProbes(nominal, trials, current.augmented, &skips);
  const Eigen::MatrixXd Q = TentativeBasis(nominal, trials, current, res, options, &skips);
  std::vector<double> probe_share(probes.size(), 0.0);
  std::vector<int> probe_rank(probes.size(), 0);
  std::vector<ColumnLoss> lost(probes.size());
  StageProgress progress(options, "trace: probes evaluated", probes.size(), true);
  ParallelFor(probes.size(), options, [&](size_t i) {
    struct Finish {  // reports the probe however its task returns
      StageProgress& progress;
      const std::string& what;
      std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
      ~Finish() { progress.Done(what, SecondsSince(start)); }
    } finish{progress, probes[i].variable};
    Eigen::MatrixXd D = ProbeColumns(probes[i].models, trials, current, res, options, &lost[i]);
    if (!probes[i].multipliers.empty()) {
      const std::vector<std::vector<double>>& mult = probes[i].multipliers;
      Eigen::MatrixXd E(D.rows(), D.cols() * static_cast<long>(mult.size()));
      for (long c = 0; c < D.cols(); ++c) {
        for (size_t j = 0; j < mult.size(); ++j) {
          for (size_t k = 0; k < trials.size(); ++k) {
            E.block<6, 1>(6 * static_cast<long>(k), c * static_cast<long>(mult.size()) + j) =
                mult[j][k] * D.block<6, 1>(6 * static_cast<long>(k), c);
          }
        }
      }
      D = std::move(E);
    }
    if (D.cols() == 0 || !(res.total > 0)) return;
    if (Q.cols() > 0) D -= Q * (Q.transpose() * D);
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(D);
    probe_rank[i] = static_cast<int>(qr.rank());
    if (probe_rank[i] == 0) return;
    const Eigen::VectorXd projected = D * qr.solve(res.stacked);
    probe_share[i] = std::min(1.0, projected.squaredNorm() / res.total);
  });
  ColumnLoss all_lost;
  long columns = 0;
  for (size_t i = 0; i < probes.size(); ++i) {
    columns += static_cast<long>(probes[i].models.size());
    if (lost[i].columns > 0) {
      if (all_lost.columns == 0) all_lost.why = probes[i].variable + ": " + lost[i].why;
      all_lost.columns += lost[i].columns;
    }
    if (probe_rank[i] == 0) continue;
    items.push_back({probes[i].variable, probe_share[i], probes[i].note});
    chance.push_back(probe_rank[i]);
  }
  skips.Add(
      "probe columns incomplete (the probe model cannot predict every trial: those rows "
      "count as zero)",
      all_lost.columns, columns, all_lost.why);
  ListTrace(trials, res, std::move(items), chance, report);
  skips.AddTo(report);
}

}  // namespace isowrench::ident
