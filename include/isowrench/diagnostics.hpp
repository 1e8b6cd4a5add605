#pragma once
/// @file
/// Diagnostics of a restrained limb (docs/diagnostics.md): which class of constraint it is
/// (over-constrained, matched, under-constrained), its self-motions and internal wrenches, how
/// much the measured wrench depends on each unmeasured compliance, which extra transducer dof
/// to release, and how far the linear (small-motion) answer is from the nonlinear equilibrium.
///
/// Scaling used for every rank decision: the Jacobian is made dimensionless by dividing its
/// translation rows by a length scale L (the leg length, Model::chain_length(), unless an
/// option says otherwise) and multiplying prismatic columns by L. Singular values are then in
/// rad/rad; the rank threshold is rank_tolerance * sigma_max and is reported.
///
/// Wrench sign as in statics.hpp: W is the wrench the limb applies TO the transducer, [f; m] in
/// N and N·m, moment about the endpoint origin, in transducer axes.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "isowrench/model.hpp"
#include "isowrench/statics.hpp"

namespace isowrench {

// ---- Constraint class, self-motion, internal wrench ------------------------------------

/// How the restrained transducer dofs compare with the limb's joint dofs, from
/// r = rank(J_r), n = restrained dofs and m = joint dofs (J_r = J on the restrained rows).
enum class ConstraintClass {
  kMatched,           ///< r = n = m: W = J_r^-T tau, whatever the compliances (if S_p = 0)
  kOverConstrained,   ///< r = m < n: internal wrenches exist; W depends on the compliances
  kUnderConstrained,  ///< r = n < m: self-motions exist; only joint stiffness can hold them
  kDeficient,         ///< r < n and r < m: both internal wrenches and self-motions
};
/// "matched", "over-constrained", "under-constrained", "over- and under-constrained".
const char* ConstraintClassName(ConstraintClass c);

/// Options of AnalyzeConstraints. Each states the inequality it controls.
struct ConstraintOptions {
  /// A singular value sigma_i of the scaled J_r counts as zero when
  /// sigma_i <= rank_tolerance * sigma_max.
  double rank_tolerance = 1e-9;
  /// Length scale L (m) dividing translation rows; <= 0 means Model::chain_length().
  double length_scale = 0.0;
  /// A component of an internal-wrench direction (scaled to unit norm, forces times L) is
  /// "touched" when |component| > component_cutoff.
  double component_cutoff = 1e-6;
};

/// A joint-space direction in named joints, with a geometric reading when one is found.
struct JointMotion {
  Eigen::VectorXd direction;   ///< m entries (rad or m per joint), largest |entry| = 1
  std::string joints;          ///< DescribeJointMotion(), e.g. "hip_rx +1.00, knee_ry +0.97"
  std::string interpretation;  ///< e.g. "femur axial rotation (about the hip-knee line)", or ""
};

/// A direction of null(J_r^T): a wrench on the restrained dofs the joints cannot feel.
struct InternalWrench {
  /// N and N·m, transducer axes; released rows and untouched components exactly 0; largest
  /// |force| = 1 N when forces dominate (|f|_max >= |m|_max / L), else largest |moment| = 1 N·m.
  Vector6d direction = Vector6d::Zero();
  std::vector<int> components;  ///< indices (x..rz = 0..5) the direction touches
  std::string description;      ///< e.g. "fx +1.000 N, fy -0.532 N, mz +0.0123 N·m"
};

/// A revolute joint centre: consecutive joints that share one world position, named by their
/// common prefix ("hip" for hip_rz, hip_ry, hip_rx).
struct JointCentre {
  std::string name;
  std::vector<std::string> joints;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< m, world
};

/// Revolute joint centres at posture q, proximal first (the endpoint is not one).
/// @throws Error if q has the wrong size or a non-finite entry.
std::vector<JointCentre> FindJointCentres(const Model& model, const Eigen::VectorXd& q);

/// Posture-only analysis of J_r (no muscle): rank, class, self-motions, internal wrenches. J_r is
/// J on the restrained rows and on the columns of K (StaticsProblem::columns(): every coordinate
/// that is not locked).
struct ConstraintAnalysis {
  /// m, the joint dofs of the restrained limb: the coordinates that are columns of K (all roles;
  /// locked coordinates are rigid and not counted, StaticsProblem::columns()).
  int joint_count = 0;
  std::vector<std::string> locked;  ///< the locked coordinates left out of J_r
  int restrained_count = 0;         ///< n, restrained transducer dofs
  DofMask restrained;               ///< which they are (names(): x y z rx ry rz)
  int rank = 0;                     ///< rank of J_r
  double length_scale = 0.0;        ///< L (m) used for scaling
  Eigen::VectorXd singular_values;  ///< of the scaled J_r, descending, dimensionless
  double rank_tolerance = 0.0;      ///< the option used
  double rank_threshold = 0.0;      ///< rank_tolerance * sigma_max
  ConstraintClass constraint_class = ConstraintClass::kMatched;
  std::string explanation;  ///< one sentence: what the class means for this limb
  /// Basis of null(J_r), each direction over all coordinates (0 on locked ones).
  std::vector<JointMotion> self_motion;
  std::vector<InternalWrench> internal_wrench;  ///< basis of null(J_r^T) on the restrained rows
  /// The same classification on the columns without a joint spring (S_p = 0): this one says
  /// whether W depends on the compliances (springs hold their joints, so base dofs or a
  /// stiff extra joint do not count as self-motion here).
  int free_joint_count = 0;
  int free_rank = 0;
  ConstraintClass free_class = ConstraintClass::kMatched;
  Matrix6Xd jacobian;  ///< J_T_E (6 x m) at q, transducer axes
};

/// Rank and SVD of the scaled J_r at q, the constraint class, null(J_r) as named joint motions
/// and null(J_r^T) as internal wrenches.
/// @throws Error if q has the wrong size or a non-finite entry, or an option is not finite.
ConstraintAnalysis AnalyzeConstraints(const Model& model, const Eigen::VectorXd& q,
                                      const ConstraintOptions& options = {});

// ---- Sensitivity to the compliances ---------------------------------------------------

/// dW/d(log k) for one stiffness k: how much W changes when k is scaled by e (first order).
struct StiffnessSensitivity {
  std::string parameter;   ///< "S_t x" ... "S_t rz", a joint name, or "base (x, y, z together)"
  std::string kind;        ///< "transducer", "base", "joint"
  double stiffness = 0.0;  ///< the value k (unit below)
  std::string unit;        ///< "N/m" or "N·m/rad"
  Vector6d dW_dlogk = Vector6d::Zero();  ///< N and N·m, transducer axes
  /// |D dW| / |D W| with D = diag(1, 1, 1, 1/L, 1/L, 1/L): dimensionless.
  double relative = 0.0;
};

/// Analytic dW/dlog k (K dtheta = tau, W = S_t J dtheta; for a diagonal entry k with
/// dK/dk = A: d dtheta = -K^+ A dtheta, dW = dS_t J dtheta + S_t J d dtheta) for every
/// restrained transducer stiffness, every joint with a spring, and the three base
/// translations together. K^+ is the pseudo-inverse on the non-null eigenvalues of K.
struct SensitivityResult {
  bool ok = false;  ///< false when the statics has no unique W (self-motion, bad input)
  std::string message;
  std::vector<StiffnessSensitivity> entries;
};

/// Sensitivities for an evaluation from EvaluateWrench (uses its J, S_t, S_p, tau, dtheta).
/// Never throws.
SensitivityResult ComputeStiffnessSensitivity(const Model& model,
                                              const WrenchEvaluation& evaluation,
                                              double length_scale = 0.0,
                                              double rank_tolerance = 1e-12);

// ---- Large deflection ----------------------------------------------------------------

/// Options of SolveLargeDeflection (Newton's method on the potential).
struct LargeDeflectionOptions {
  int max_iterations = 200;
  /// Converged when |gradient|_inf <= gradient_tolerance * max(|tau|_inf, tiny), or when
  /// the Newton step |step|_inf <= step_tolerance * max(|dtheta|_inf, 1e-300).
  double gradient_tolerance = 1e-13;
  double step_tolerance = 1e-12;
  /// Largest joint change per iteration, rad (prismatic: times L); limits wild first steps.
  double max_step = 0.2;
};

enum class LargeDeflectionStatus {
  kConverged,     ///< a stable equilibrium (Hessian positive definite) was found
  kUnstable,      ///< converged to a stationary point whose Hessian is not positive definite
  kNotConverged,  ///< iteration limit reached or no descent possible
  kFailed,        ///< the geometry broke down (e.g. a muscle segment of zero length)
};
const char* LargeDeflectionStatusName(LargeDeflectionStatus s);

/// Nonlinear equilibrium of the restrained limb with forward kinematics updated (the unknowns
/// are the columns of K, StaticsProblem::columns(): locked coordinates stay at q):
/// minimise U(theta) = 1/2 e^T S_t e + 1/2 dtheta^T S_p dtheta + F (L(theta) - L(theta0)),
/// e = [R_T^T (p - p0); R_T^T log(R R0^T)] the endpoint pose error in transducer axes
/// (translation, rotation vector from the log map), the transducer fixed at the initial pose.
/// The nonlinear wrench is W_nl = S_t e (released rows 0), to compare with the linear Eq. 10.
struct LargeDeflectionResult {
  LargeDeflectionStatus status = LargeDeflectionStatus::kNotConverged;
  std::string message;
  int iterations = 0;
  double gradient_norm = 0.0;                    ///< |grad U|_inf at the end (N·m or N)
  Eigen::VectorXd dtheta_nonlinear;              ///< theta* - theta0 (rad / m)
  Eigen::VectorXd dtheta_linear;                 ///< K^+ tau (rad / m)
  Vector6d wrench_nonlinear = Vector6d::Zero();  ///< N, N·m, transducer axes
  Vector6d wrench_linear = Vector6d::Zero();     ///< Eq. 10
  double dtheta_difference = 0.0;                ///< |dtheta_nl - dtheta_lin|_inf (rad / m)
  double displacement = 0.0;  ///< |dtheta_lin|_inf (rad / m), the size of the motion
  /// |D (W_nl - W_lin)| / |D W_lin|, D = diag(1,1,1,1/L,1/L,1/L).
  double wrench_relative_difference = 0.0;
  /// A nonlinear equilibrium was found (kConverged or kUnstable). Otherwise dtheta_nonlinear and
  /// wrench_nonlinear are the last iterate, no answer: reports print no wrench for them.
  bool found() const {
    return status == LargeDeflectionStatus::kConverged ||
           status == LargeDeflectionStatus::kUnstable;
  }
};

/// Solve the nonlinear equilibrium for `muscle` at activation `activation` from posture q.
/// @throws Error for unknown muscles or a bad posture; numerical failure is a status.
LargeDeflectionResult SolveLargeDeflection(const Model& model, const Eigen::VectorXd& q,
                                           const std::string& muscle, double activation = 1.0,
                                           const LargeDeflectionOptions& options = {});

/// Gradient of the potential U of SolveLargeDeflection at theta (exposed for tests):
/// J_e^T S_t e + S_p (theta - theta0) - tau_muscle(theta), with J_e the derivative of e
/// (the log map's inverse left Jacobian applied to the rotation rows). Also returns U.
/// @throws Error as ComputeMuscleTorque does.
Eigen::VectorXd LargeDeflectionGradient(const Model& model, const Eigen::VectorXd& q0,
                                        const Eigen::VectorXd& theta, int muscle_index,
                                        double activation, double* potential = nullptr,
                                        Vector6d* wrench = nullptr);

// ---- Whole diagnosis -------------------------------------------------------------------

struct DiagnosisOptions {
  ConstraintOptions constraints;
  StaticsOptions statics;
  double activation = 1.0;
  bool large_deflection = true;  ///< run SolveLargeDeflection too
  LargeDeflectionOptions large_deflection_options;
  /// W depends on the compliances when some relative sensitivity |D dW| / |D W| (per e-fold of
  /// a stiffness) > sensitivity_tolerance (the release comparison's spread_tolerance).
  double sensitivity_tolerance = 1e-6;
};

/// DiagnoseLimb's result for one muscle at one posture.
struct Diagnosis {
  ConstraintAnalysis constraints;
  WrenchEvaluation evaluation;              ///< Eq. 10 with the model's compliances
  std::vector<JointMotion> stiffness_null;  ///< basis of null(K): self-motion no spring holds
  /// The part of W the compliances set: W - W_classic (pinv(J_r^T) tau, Eq. 15) written on the
  /// internal-wrench basis, W - W_classic ~ sum_i c_i direction_i (c_i dimensionless, since
  /// each direction is in N and N·m). Empty when there is no internal wrench, no equilibrium,
  /// or base dofs (the classic answer treats their springs as free joints and means nothing).
  Eigen::VectorXd internal_coefficients;
  /// False with base dofs (StaticsProblem::base_columns()): the classic answer treats their
  /// springs as free joints and means nothing; reports then omit it.
  bool classic_meaningful = true;
  /// |D (W - W_classic - sum c_i direction_i)| / |D W| (D as in StiffnessSensitivity): 0 when
  /// all of the difference is internal, i.e. when the spring-free joints carry all of tau.
  double internal_residual = 0.0;
  SensitivityResult sensitivity;
  /// Whether W depends on the compliances, read from the sensitivities (not from the constraint
  /// class: internal wrench directions the muscle does not load leave W unchanged): the largest
  /// relative sensitivity > DiagnosisOptions::sensitivity_tolerance. False without a unique W.
  bool compliance_dependent = false;
  /// One sentence: which compliance moves W most and by how much, or that none does.
  std::string compliance_verdict;
  bool large_deflection_run = false;
  LargeDeflectionResult large_deflection;
};

/// AnalyzeConstraints + EvaluateWrench + ComputeStiffnessSensitivity (+ SolveLargeDeflection).
/// @throws Error for unknown muscles, a bad posture or bad options.
Diagnosis DiagnoseLimb(const Model& model, const Eigen::VectorXd& q, const std::string& muscle,
                       const DiagnosisOptions& options = {});

// ---- Released-dof choices --------------------------------------------------------------

enum class ReleaseKind {
  kNone,         ///< no extra release: the model as given (the baseline row)
  kRotation,     ///< rotation about an axis through the endpoint: Jacobian column [0; a]
  kTranslation,  ///< translation along an axis: Jacobian column [a; 0]
};

/// One candidate extra release, equivalent to a zero-stiffness joint between endpoint and
/// transducer (docs/model.md "Released dofs").
struct ReleaseCandidate {
  std::string name;  ///< e.g. "rz", "endpoint-knee line", "user 1"
  ReleaseKind kind = ReleaseKind::kRotation;
  Eigen::Vector3d axis_world = Eigen::Vector3d::UnitZ();  ///< unit, world axes
  std::string source;  ///< "transducer axis", "joint centre", "user", "baseline"
};

/// A user axis through the endpoint. @throws Error naming `name` if the axis has a non-finite
/// component or zero length (|axis| <= 1e-12).
ReleaseCandidate MakeReleaseCandidate(const std::string& name, ReleaseKind kind,
                                      const Eigen::Vector3d& axis_world);

/// The transducer axes that are still restrained (rotations, then translations) and the
/// rotations about the lines from the endpoint to each proximal joint centre.
std::vector<ReleaseCandidate> DefaultReleaseCandidates(const Model& model,
                                                       const Eigen::VectorXd& q);

/// Transducer and base stiffness range a release is tested over (stated in every output).
struct StiffnessRange {
  double translational = 1e7;  ///< N/m, the transducer's kx = ky = kz
  std::vector<double> rotational_ratios{1e-4, 1e-3, 1e-2, 1e-1, 1.0};     ///< krot/ktrans, m²/rad
  std::vector<double> base_stiffness{0.0, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9};  ///< N/m, 0 = rigid
  std::string Describe() const;
};

struct ReleaseOptions {
  double rank_tolerance = 1e-9;  ///< self-motion when sigma_min <= rank_tolerance * sigma_max
  /// Safe only when sigma_min / sigma_max > margin_warning (otherwise "near self-motion").
  double margin_warning = 1e-2;
  double length_scale = 0.0;  ///< L (m); <= 0 means Model::chain_length()
  /// A spread |D(W - W_model)| / |D W_model| below this counts as compliance-independent.
  double spread_tolerance = 1e-6;
  double activation = 1.0;
  StiffnessRange range;
  StaticsOptions statics;
};

/// Assessment of one candidate. Rank and margin are those of the expanded, scaled Jacobian
/// J_e = [J_r | j_r] on the columns WITHOUT a spring (joints with S_p > 0, e.g. base dofs, are
/// held by their stiffness: K v = 0 needs J_r v = 0 and S_p v = 0).
struct ReleaseAssessment {
  ReleaseCandidate candidate;
  Eigen::Vector3d axis_transducer = Eigen::Vector3d::Zero();  ///< the axis in transducer axes
  int rank = 0;                   ///< rank of J_e on the spring-free columns
  int columns = 0;                ///< spring-free joints (+ 1 for a release)
  double margin = 0.0;            ///< sigma_min / sigma_max of the scaled J_e (dimensionless)
  bool self_motion = false;       ///< rank < columns: the release lets the limb move freely
  bool near_self_motion = false;  ///< margin <= margin_warning
  bool internal_wrench = false;   ///< rank < restrained rows: W depends on compliance
  /// Muscle joint torques tau follow from the measured wrench (tau = J^T W on spring-free
  /// joints) and distinct torques give distinct wrenches: J_e has full column rank.
  bool torques_recoverable = false;
  StaticsResult statics;                   ///< Eq. 10 with the model's compliances and this release
  Vector6d wrench_min = Vector6d::Zero();  ///< per component over the stiffness range
  Vector6d wrench_max = Vector6d::Zero();
  double spread = 0.0;     ///< max over the range of |D(W - W_model)| / |D W_model|
  int range_failures = 0;  ///< grid points with no equilibrium
  int rank_order = 0;      ///< 1 = recommended; 0 = not ranked (self-motion)
  std::string verdict;     ///< one line: why it is good or bad
};

/// Forbidden axes of one kind: the subspace of axes a whose release column lies in the range of
/// J_r restricted to its spring-free columns (releasing such an axis creates a self-motion).
struct ForbiddenAxes {
  int dimension = 0;       ///< 0 none, 1 one axis, 2 a plane, 3 every axis
  Eigen::Matrix3Xd basis;  ///< 3 x dimension, orthonormal, world axes
  Eigen::Vector3d plane_normal = Eigen::Vector3d::Zero();  ///< world, when dimension == 2
  std::string description;
};

/// Everything `isowrench releases` prints.
struct ReleaseComparison {
  std::string muscle;
  double length_scale = 0.0;
  std::string range_description;
  ReleaseAssessment baseline;                 ///< the model as given
  std::vector<ReleaseAssessment> candidates;  ///< in input order
  ForbiddenAxes forbidden_rotations;          ///< rotations about axes through the endpoint
  ForbiddenAxes forbidden_translations;
  /// False when the baseline already gives a W that does not depend on the compliances (spread
  /// <= ReleaseOptions::spread_tolerance, no self-motion): then nothing is recommended.
  bool release_needed = true;
  int recommended = -1;        ///< index into candidates, -1 if none is safe or none is needed
  std::string recommendation;  ///< the reason, one paragraph
};

/// Assess a single candidate (used by CompareReleases and SweepReleaseAxes).
/// @throws Error for unknown muscles or a bad posture.
ReleaseAssessment AssessRelease(const Model& model, const Eigen::VectorXd& q,
                                const std::string& muscle, const ReleaseCandidate& candidate,
                                const ReleaseOptions& options = {});

/// Forbidden rotation and translation axes at q (first: rotations, second: translations).
std::pair<ForbiddenAxes, ForbiddenAxes> FindForbiddenAxes(const Model& model,
                                                          const Eigen::VectorXd& q,
                                                          const ReleaseOptions& options = {});

/// Assess `candidates` (DefaultReleaseCandidates when empty) plus the baseline, find the
/// forbidden axes and rank the safe candidates: no internal wrench first, then the smallest
/// spread over the stiffness range, then the largest margin.
/// @throws Error for unknown muscles or a bad posture.
ReleaseComparison CompareReleases(const Model& model, const Eigen::VectorXd& q,
                                  const std::string& muscle,
                                  std::vector<ReleaseCandidate> candidates = {},
                                  const ReleaseOptions& options = {});

/// Random rotation axes through the endpoint (uniform on the sphere, std::mt19937_64(seed)).
struct AxisSweep {
  int samples = 0;
  std::uint64_t seed = 0;
  int already_free = 0;  ///< axes whose rotation the model's released dofs already allow
  int self_motion = 0;   ///< margin <= rank_tolerance
  int near = 0;          ///< rank_tolerance < margin <= margin_warning
  int safe = 0;          ///< margin > margin_warning
  double smallest_margin = 0.0;
  Eigen::Vector3d worst_axis = Eigen::Vector3d::Zero();  ///< world, the axis of smallest margin
};

/// Sample `count` random axes and classify each by its expanded-Jacobian margin.
/// @throws Error if count < 1 or the posture is bad.
AxisSweep SweepReleaseAxes(const Model& model, const Eigen::VectorXd& q, int count,
                           std::uint64_t seed, const ReleaseOptions& options = {});

// ---- Several postures ------------------------------------------------------------------

/// One posture row from a CSV table.
struct NamedPosture {
  std::string label;  ///< the "label" column, or "row N"
  Eigen::VectorXd q;  ///< rad / m, model column order
};

/// Read a CSV of postures: header row of joint names (an optional "label" column), then one
/// row per posture in degrees (mm for prismatic joints). Joints not in the header keep their
/// value from `base`. Blank lines and lines starting with '#' are skipped.
/// @throws Error naming file:line and column for unknown joints, wrong column counts and
///         values that are not finite numbers.
std::vector<NamedPosture> ReadPostureTable(const Model& model, const std::string& path,
                                           const Eigen::VectorXd& base);

/// Same, for text already in memory; `source_name` appears in messages.
std::vector<NamedPosture> ParsePostureTable(const Model& model, const std::string& text,
                                            const std::string& source_name,
                                            const Eigen::VectorXd& base);

}  // namespace isowrench
