#pragma once
/// @file
/// Statics of the compliantly restrained limb (paper Eq. 6-10, docs/model.md "Statics"):
///   K = J^T S_t J + S_p,   K dtheta = tau,   W = S_t J dtheta,
/// and the classic answers it is compared with: J^-T tau (Eq. 11/14) and pinv(J^T) tau (Eq. 15).
/// W is the wrench the limb applies TO the transducer, [f; m] in N and N·m, moment about the
/// endpoint origin, in transducer axes (released components are exactly 0).

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "isowrench/kinematics.hpp"
#include "isowrench/model.hpp"

namespace isowrench {

/// Options of SolveStatics. Each states the inequality it controls.
struct StaticsOptions {
  /// Eigenvalue lambda_i of K counts as zero (a self-motion) when
  /// lambda_i <= rank_tolerance * lambda_max. Reported in the result.
  double rank_tolerance = 1e-12;
  /// tau excites a self-motion direction n (unit) when |n . tau| > excitation_tolerance * |tau|.
  double excitation_tolerance = 1e-9;
  /// Small-motion rule, translation: |endpoint translation| <= max_endpoint_fraction * leg length.
  double max_endpoint_fraction = 1e-3;
  /// Small-motion rule, rotation: |dtheta_i| <= max_joint_rotation (rad) for revolute joints,
  /// and |dtheta_i| <= max_endpoint_fraction * leg length for prismatic ones.
  double max_joint_rotation = 0.01;
  /// Leg length (m) for the translation rule; <= 0 means the model's (Model::chain_length(),
  /// StaticsProblem::leg_length()).
  double leg_length = 0.0;
};

/// Outcome of every solve (SolveStatics, EvaluateWrench, Evaluate, EvaluateBatch,
/// SolveStatics, ClassicWrench): one convention, each result carrying one of these and,
/// where it can hold one (all but the 64-byte WrenchResult), a message.
enum class StaticsStatus {
  kOk,  ///< unique W; K positive definite (classic: J_r^T W = tau solved exactly)
  /// K singular but tau does not excite the self-motion: W still unique. Classic: J_r is rank
  /// deficient but tau is reachable (minimum-norm W).
  kSelfMotionHeld,
  /// K singular and tau excites it: no equilibrium; W is not defined (zeros). Classic: the
  /// restrained rows cannot balance tau (residual > 0); W is the least-squares answer.
  kSelfMotion,
  kInvalidInput,  ///< non-finite, negative or mis-sized input; see message; W zeros
};
/// "ok", "self-motion (not excited)", "self-motion", "invalid input".
const char* StatusName(StaticsStatus status);

/// Result of SolveStatics (Ceres-style summary: status + message + data).
struct StaticsResult {
  StaticsStatus status = StaticsStatus::kInvalidInput;
  std::string message;
  /// W [f; m] in transducer axes (N, N·m); released rows are 0. Zero when status is kSelfMotion
  /// or kInvalidInput.
  Vector6d wrench = Vector6d::Zero();
  /// dtheta = K^+ tau (rad or m per joint), the equilibrium displacement.
  Eigen::VectorXd dtheta;
  /// Endpoint displacement J dtheta [m; rad] in transducer axes.
  Vector6d endpoint_displacement = Vector6d::Zero();
  /// Residual of equilibrium |J^T W + S_p dtheta - tau| (N·m), a check on the solve.
  double equilibrium_residual = 0.0;
  /// Eigenvalues of K, ascending, and the rank decision.
  Eigen::VectorXd k_eigenvalues;
  double rank_threshold = 0.0;  ///< absolute threshold: rank_tolerance * lambda_max
  int k_rank = 0;
  double k_condition = 0.0;  ///< lambda_max / lambda_min over the non-null eigenvalues
  /// Self-motion basis: columns span null(K), unit length (m x r; r = 0 when K is regular).
  Eigen::MatrixXd self_motion;
  /// Small-motion check (docs/model.md "Validity of the linear model").
  bool small_motion_valid = true;
  double endpoint_translation = 0.0;        ///< |J dtheta|_translation (m)
  double endpoint_translation_limit = 0.0;  ///< max_endpoint_fraction * leg length (m)
  double max_joint_rotation = 0.0;          ///< max |dtheta_i| over revolute joints (rad)
  double max_joint_rotation_limit = 0.0;    ///< rad
  std::string validity_message;             ///< empty when valid

  bool ok() const {
    return status == StaticsStatus::kOk || status == StaticsStatus::kSelfMotionHeld;
  }
};

/// Solve the statics on raw matrices, for lab tools that compute J themselves.
/// @param J     6 x m endpoint Jacobian, rows [v; w] in the transducer's axes.
/// @param s_t   S_t diagonal (N/m, N·m/rad), >= 0. A zero entry is a released dof (same as
///              deleting that row of J, see docs/model.md "Released dofs").
/// @param s_p   S_p diagonal, m entries (N·m/rad or N/m), >= 0.
/// @param tau   m joint torques (N·m or N).
/// @param revolute m flags (true: revolute) for the small-motion rule; empty = all revolute.
/// Never throws; bad input gives status kInvalidInput.
StaticsResult SolveStatics(const Matrix6Xd& J, const Vector6d& s_t, const Eigen::VectorXd& s_p,
                           const Eigen::VectorXd& tau, const StaticsOptions& options = {},
                           const std::vector<bool>& revolute = {});

/// The classic answers without compliance, on the restrained rows (the dofs not in `released`):
/// J_r^-T tau when J_r is square and invertible (Eq. 11/14), otherwise pinv(J_r^T) tau =
/// J_r (J_r^T J_r)^-1 tau (Eq. 15), by SVD with threshold rank_tolerance * sigma_max.
struct ClassicResult {
  /// kOk, kSelfMotionHeld (J_r rank deficient, tau reachable), kSelfMotion (tau not reachable:
  /// |J_r^T W - tau| > 1e-9 |tau|), or kInvalidInput (wrench zeros); never silent.
  StaticsStatus status = StaticsStatus::kInvalidInput;
  std::string message;                 ///< what was solved, or why nothing was
  Vector6d wrench = Vector6d::Zero();  ///< [f; m], transducer axes, released rows 0
  bool square_inverse = false;         ///< true: J_r^-T tau; false: pseudoinverse
  int rank = 0;                        ///< rank of J_r
  double residual = 0.0;               ///< |J_r^T W_r - tau|: > 0 when tau is not reachable
};
ClassicResult ClassicWrench(const Matrix6Xd& J, const DofMask& released, const Eigen::VectorXd& tau,
                            double rank_tolerance = 1e-10);

// ---- The statics problem of a model: one definition every solver and report reads ----------

/// What the statics does with one coordinate (one column of J, tau and S_p).
enum class CoordinateUse {
  kFree,    ///< a column of K without a spring (S_p entry 0): only the transducer holds it
  kSpring,  ///< a column of K held by its own spring (S_p entry > 0): base, extra, stiff joints
  kLocked,  ///< held rigid (CoordinateSpec::locked): not a column of K; dtheta = 0 there
};
/// "free", "spring", "locked".
const char* CoordinateUseName(CoordinateUse use);

/// The statics problem of a Model with one set of compliances (docs/model.md "Locked
/// coordinates"): which coordinates are columns of K = J^T S_t J + S_p (free or held by a spring)
/// and which are locked (rigid, no column), the effective stiffnesses (S_t with released dofs 0,
/// S_p per coordinate) and the leg length the small-motion rule and the diagnostics' scaling use.
/// Every solver asks it (EvaluateWrench, the diagnostics, the release comparison, the fit's
/// effects), so that a locked coordinate means the same everywhere: the reduced problem has the
/// K columns only, and results map back to all m coordinates with 0 on the locked ones.
/// Cheap to build (copies the Model handle and a few vectors).
class StaticsProblem {
 public:
  /// The model's own compliances (Model::model_stiffness()).
  explicit StaticsProblem(const Model& model);
  /// Other compliances on the same model (locks, roles and leg length are the model's).
  /// @throws Error if stiffness.s_p does not have model.dof_count() entries.
  StaticsProblem(const Model& model, const StiffnessSet& stiffness);

  const Model& model() const { return model_; }
  /// S_t diagonal with released dofs 0 (N/m, N·m/rad), S_p per coordinate (m entries).
  /// The accessors returning containers return a copy when called on a temporary
  /// (`for (int c : StaticsProblem(model).columns())` is safe).
  const StiffnessSet& stiffness() const& { return stiffness_; }
  StiffnessSet stiffness() && { return std::move(stiffness_); }
  /// m, the model's coordinates (columns of J).
  int coordinate_count() const { return static_cast<int>(use_.size()); }
  /// @throws std::out_of_range for a column outside [0, m).
  CoordinateUse use(int column) const { return use_.at(static_cast<size_t>(column)); }
  bool locked(int column) const { return use(column) == CoordinateUse::kLocked; }
  /// What reports print as a coordinate's role: "locked" for a locked coordinate, otherwise
  /// RoleName() of its role ("limb", "base", "extra", "release").
  const char* RoleLabel(int column) const;
  /// The columns of K (every coordinate that is not locked), ascending: column i of the reduced
  /// problem is coordinate columns()[i].
  const std::vector<int>& columns() const& { return columns_; }
  std::vector<int> columns() && { return std::move(columns_); }
  /// The columns of K without a spring (use kFree), ascending.
  const std::vector<int>& spring_free_columns() const& { return spring_free_; }
  std::vector<int> spring_free_columns() && { return std::move(spring_free_); }
  /// The locked coordinates, ascending.
  const std::vector<int>& locked_columns() const& { return locked_; }
  std::vector<int> locked_columns() && { return std::move(locked_); }
  /// The columns of K with role kBase (base translation dofs), ascending. With base dofs the
  /// classic answers (ClassicWrench) treat the base springs as free joints and mean nothing.
  const std::vector<int>& base_columns() const& { return base_; }
  std::vector<int> base_columns() && { return std::move(base_); }
  /// Names of the locked coordinates, in column order.
  std::vector<std::string> LockedNames() const;
  /// Leg length (m): Model::chain_length(), the length through the joint centres.
  double leg_length() const;

  /// J (6 x m) on the columns of K: 6 x columns().size().
  Matrix6Xd Reduce(const Matrix6Xd& J) const;
  /// A per-coordinate vector (m entries: tau, S_p, q) on the columns of K.
  Eigen::VectorXd Reduce(const Eigen::VectorXd& v) const;
  /// S_p on the columns of K.
  Eigen::VectorXd reduced_s_p() const { return Reduce(Eigen::VectorXd(stiffness_.s_p)); }
  /// true for revolute columns of K (the small-motion rule's flags).
  std::vector<bool> reduced_revolute() const;
  /// Back to all m coordinates: `reduced` (columns().size() entries) with 0 on locked ones.
  Eigen::VectorXd Expand(const Eigen::VectorXd& reduced) const;
  /// The same for the rows of a matrix (e.g. a self-motion basis, one column per direction).
  Eigen::MatrixXd ExpandRows(const Eigen::MatrixXd& reduced) const;

  /// Eq. 10 on the columns of K (SolveStatics on the reduced J, S_p and tau), with dtheta and
  /// the self-motion basis mapped back to m rows (0 on locked coordinates). J: 6 x m in
  /// transducer axes; tau: m entries. options.leg_length <= 0 means leg_length(). Never throws.
  StaticsResult Solve(const Matrix6Xd& J, const Eigen::VectorXd& tau,
                      const StaticsOptions& options = {}) const;
  /// ClassicWrench on the columns of K and the model's restrained rows.
  ClassicResult Classic(const Matrix6Xd& J, const Eigen::VectorXd& tau) const;

 private:
  Model model_;
  StiffnessSet stiffness_;
  std::vector<CoordinateUse> use_;
  std::vector<int> columns_, spring_free_, locked_, base_;
};

/// Everything about one muscle at one posture on a model: kinematics, muscle torque, statics
/// with the model's S_t, S_p and released dofs, and the classic comparison.
struct WrenchEvaluation {
  Eigen::VectorXd q;      ///< posture (rad / m)
  Matrix6Xd jacobian;     ///< J_T_E, transducer axes, all 6 rows
  Eigen::Matrix3d R_W_T;  ///< transducer axes in world
  std::string muscle;
  double muscle_length = 0.0;  ///< m (L_MT)
  double muscle_force = 0.0;   ///< N: force.force
  /// The force stage at this length and activation (MuscleForceAt): force, active and passive
  /// parts, fiber length, pennation, status, opensim_gives_no_number.
  MuscleForce force;
  Eigen::VectorXd tau;  ///< N·m / N
  /// The passive (activation 0) evaluation at the same posture: the force stage at a = 0 (a
  /// force model's activation floor included: OpenSim's minimum_activation), its torque and
  /// statics, i.e. the pre-stimulus baseline a lab subtracts. A constant-force muscle: force 0,
  /// tau 0, W 0.
  MuscleForce passive_force;
  Eigen::VectorXd passive_tau;  ///< N·m / N
  StaticsResult passive_statics;
  Vector6d s_t;         ///< effective S_t diagonal (0 on released dofs)
  Eigen::VectorXd s_p;  ///< S_p per coordinate (locked ones are rigid whatever it says)
  /// Per coordinate: true when locked (held rigid; dtheta 0 there): StaticsProblem::locked().
  std::vector<bool> locked;
  StaticsResult statics;                     ///< W in transducer axes
  Vector6d wrench_world = Vector6d::Zero();  ///< W rotated to world axes
  ClassicResult classic;                     ///< J^-T / pinv comparison on the restrained rows
};

/// Evaluate `muscle` (by name) at posture q with activation in [0, 1]: F = MuscleForceAt(L_MT,
/// a) (a * max_force for a constant-force muscle), and the passive (activation 0) evaluation.
/// The statics is StaticsProblem(model).Solve(): locked coordinates are rigid. Where the force
/// model has no equilibrium (force.status kNoEquilibrium) tau is 0 and W is not computed
/// (statics.status kInvalidInput).
/// @throws Error for unknown muscle names, a posture of the wrong size / non-finite, or an
///         activation outside [0, 1].
WrenchEvaluation EvaluateWrench(const Model& model, const Eigen::VectorXd& q,
                                const std::string& muscle, double activation = 1.0,
                                const StaticsOptions& options = {});

/// The same with a caller-owned workspace and a muscle index, for repeated evaluations (no new
/// Data per call). @throws Error for a bad index or posture.
WrenchEvaluation EvaluateWrench(const Model& model, Data& data, const Eigen::VectorXd& q,
                                int muscle_index, double activation = 1.0,
                                const StaticsOptions& options = {});

/// The force model muscle `muscle` uses, as every report prints it: "constant (F = a x
/// max_force)", "millard2012, compliant tendon", "millard2012, rigid tendon", "thelen2003,
/// rigid-tendon limit (tendon_slack_length 0: OpenSim gives no number)".
/// @throws Error for a muscle index out of range.
std::string ForceModelLabel(const Model& model, int muscle);

/// Where OpenSim gives no number for this force evaluation (MuscleForce::
/// opensim_gives_no_number), why and what isowrench computes instead; "" where OpenSim gives
/// one. @throws Error for a muscle index out of range.
std::string OpenSimNote(const Model& model, int muscle, const MuscleForce& force);

/// "hip_rx +1.00, knee_ry +0.97, knee_rx +0.26": a joint-space direction in named joints,
/// scaled so the largest |entry| is 1, entries below `cutoff` omitted.
std::string DescribeJointMotion(const Model& model, const Eigen::VectorXd& direction,
                                double cutoff = 0.01);

}  // namespace isowrench
