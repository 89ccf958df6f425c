#include "motion/leg_ik.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace ragdoll::motion {

using character::Character;
using character::CharacterJoint;
using character::Conjugate;
using character::DataPtr;
using character::Multiply;
using character::Normalized;
using character::Quat;
using character::Vec3;

namespace {

constexpr int kHinges = 7;  // hip (3), knee, ankle (3)
constexpr int kMaxIterations = 200;
// Converged: far below anything a clip file (six decimals) or a simulation can tell apart.
constexpr double kPositionTolerance = 1e-10;
constexpr double kAngleTolerance = 1e-10;
// Damping lambda = kDampingGain |error| + kMinDamping: strong far from the target, where the
// linearisation is poor and a straight knee makes the Jacobian singular, and vanishing near it,
// so that the iteration ends at the exact solution rather than short of it.
constexpr double kDampingGain = 0.1;
constexpr double kMinDamping = 1e-9;
// The largest hinge change of one iteration, rad: keeps steps inside the linear range.
constexpr double kMaxStep = 0.3;
// Fraction of the way back to the starting angles taken per iteration, within the motions that
// leave the foot where it is.
constexpr double kPull = 0.2;
// A straight knee is a singular pose: no first-order motion shortens the leg, so a solve starts
// with the knee bent at least this much (radians). When the first attempt fails, the solve
// starts over with the knee bent and the thigh twisted as below, and keeps the best: joint
// limits can stop the iteration in a local minimum on the wrong side of a bend or twist.
constexpr double kMinStartKnee = 0.3;
struct Restart {
  double hip_z, knee;
};
constexpr Restart kRestarts[] = {{0, 0.8},   {0, 1.6},    {0, 2.4},  {-0.6, 0.8},
                                 {0.6, 0.8}, {-0.6, 1.6}, {0.6, 1.6}};

using Jacobian = std::array<std::array<double, kHinges>, 6>;
using Vec6 = std::array<double, 6>;

// The solve of (J J^T + lambda^2 I) y = b for the free hinges' columns of J, returned as
// J^T y: the damped least-squares step that best moves the foot by b.
std::array<double, kHinges> DampedStep(const Jacobian& jac, const bool* free, double lambda,
                                       const Vec6& b) {
  double a[36];
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      double s = r == c ? lambda * lambda : 0.0;
      for (int i = 0; i < kHinges; ++i) {
        if (free[i]) s += jac[r][i] * jac[c][i];
      }
      a[6 * r + c] = s;
    }
  }
  double y[6];
  mju_cholFactor(a, 6, 1e-15);
  mju_cholSolve(y, a, b.data(), 6);
  std::array<double, kHinges> step{};
  for (int i = 0; i < kHinges; ++i) {
    if (!free[i]) continue;
    for (int r = 0; r < 6; ++r) step[i] += jac[r][i] * y[r];
  }
  return step;
}

// One leg of one character: its hinges, the target, and the iteration.
class LegSolver {
 public:
  LegSolver(const Character& character, const std::string& side, const Vec3& position,
            const Quat& rotation, const double* qpos, mjData* d)
      : m_(character.model()),
        d_(d),
        body_(character.BodyId(side + "_ankle")),
        position_(position),
        rotation_(Normalized(rotation)),
        jacp_(3 * m_->nv),
        jacr_(3 * m_->nv) {
    int n = 0;
    const auto& joints = character.joints();
    for (const std::string& part : {side + "_hip", side + "_knee", side + "_ankle"}) {
      auto joint = std::find_if(joints.begin(), joints.end(),
                                [&](const CharacterJoint& j) { return j.name == part; });
      for (int h = 0; h < joint->axes.count; ++h, ++n) {
        int jnt = m_->body_jntadr[joint->body] + h;
        qadr_[n] = joint->qpos_address + h;
        dadr_[n] = joint->dof_address + h;
        lower_[n] = m_->jnt_range[2 * jnt];
        upper_[n] = m_->jnt_range[2 * jnt + 1];
      }
    }
    for (int i = 0; i < kHinges; ++i) start_[i] = Clamp(i, qpos[qadr_[i]]);
    std::copy(qpos, qpos + m_->nq, d_->qpos);
  }

  using Angles = std::array<double, kHinges>;
  struct Attempt {
    Angles q;
    LegIkResult result;
    double total = INFINITY;
    bool converged() const {
      return result.position_error < kPositionTolerance && result.angle_error < kAngleTolerance;
    }
  };

  const Angles& start() const { return start_; }
  int qpos_address(int i) const { return qadr_[i]; }
  double Clamp(int i, double a) const { return std::clamp(a, lower_[i], upper_[i]); }

  // The foot's error for angles `q`, as a world-frame position and rotation vector; leaves the
  // kinematics of `q` in the scratch data.
  Vec6 Error(const Angles& q, Attempt* attempt) {
    for (int i = 0; i < kHinges; ++i) d_->qpos[qadr_[i]] = q[i];
    mj_kinematics(m_, d_);
    Vec6 error;
    for (int k = 0; k < 3; ++k) error[k] = position_[k] - d_->xpos[3 * body_ + k];
    Quat now = {d_->xquat[4 * body_], d_->xquat[4 * body_ + 1], d_->xquat[4 * body_ + 2],
                d_->xquat[4 * body_ + 3]};
    Quat turn = Multiply(rotation_, Conjugate(now));
    if (turn[0] < 0) {
      for (double& c : turn) c = -c;
    }
    mju_quat2Vel(error.data() + 3, turn.data(), 1.0);
    attempt->q = q;
    attempt->result.position_error = std::hypot(error[0], error[1], error[2]);
    attempt->result.angle_error = std::hypot(error[3], error[4], error[5]);
    attempt->total = std::hypot(attempt->result.position_error, attempt->result.angle_error);
    return error;
  }

  // Iterates from `q`; returns the best angles met. A step is taken only when it brings the foot
  // closer: first with the pull to the starting angles, then without, then halved.
  Attempt Run(Angles q) {
    Attempt now, next;
    Vec6 error = Error(q, &now);
    int iteration = 0;
    for (; !now.converged() && iteration < kMaxIterations; ++iteration) {
      Angles task, pull;
      Directions(q, error, now.total, &task, &pull);
      bool moved = false;
      for (int attempt = 0; attempt < 6 && !moved; ++attempt) {
        double fraction = attempt == 0 ? 1.0 : std::ldexp(1.0, 1 - attempt);
        Angles candidate;
        for (int i = 0; i < kHinges; ++i) {
          candidate[i] = Clamp(i, q[i] + fraction * (task[i] + (attempt == 0 ? pull[i] : 0)));
        }
        Vec6 candidate_error = Error(candidate, &next);
        if (next.total < now.total) {
          q = candidate;
          error = candidate_error;
          now = next;
          moved = true;
        }
      }
      if (!moved) break;  // a local minimum: out of reach, or a limit in the way
    }
    now.result.iterations = iteration;
    return now;
  }

 private:
  // The step from angles `q` (whose kinematics the scratch data holds) with foot error `error`,
  // scaled to at most kMaxStep: `task` toward the target, `pull` toward the starting angles.
  void Directions(const Angles& q, const Vec6& error, double total, Angles* task, Angles* pull) {
    mj_comPos(m_, d_);
    mj_jacBody(m_, d_, jacp_.data(), jacr_.data(), body_);
    Jacobian jac;
    for (int i = 0; i < kHinges; ++i) {
      for (int r = 0; r < 3; ++r) {
        jac[r][i] = jacp_[m_->nv * r + dadr_[i]];
        jac[3 + r][i] = jacr_[m_->nv * r + dadr_[i]];
      }
    }
    // The damped least-squares step toward the target for the hinges left free, and for each
    // held one the slope of the remaining error along it: an active-set solve of the step
    // within the hinge limits. A hinge at a limit that the step would push further is held (the
    // one pushed hardest first), and released again when moving it back inside would help.
    double lambda = kDampingGain * total + kMinDamping;
    bool free[kHinges];
    std::fill(free, free + kHinges, true);
    Angles step{};
    for (int pass = 0; pass < 4 * kHinges; ++pass) {
      step = DampedStep(jac, free, lambda, error);
      Vec6 left = error;
      for (int r = 0; r < 6; ++r) {
        for (int i = 0; i < kHinges; ++i) left[r] -= jac[r][i] * step[i];
      }
      int change = -1;
      double largest = 0;
      for (int i = 0; i < kHinges; ++i) {
        double push;  // how hard this hinge is driven past its limit (positive) or back inside
        if (free[i]) {
          push = q[i] <= lower_[i] ? -step[i] : q[i] >= upper_[i] ? step[i] : 0;
        } else {
          double slope = 0;
          for (int r = 0; r < 6; ++r) slope += jac[r][i] * left[r];
          push = q[i] <= lower_[i] ? slope : -slope;  // inward progress when positive
        }
        if (push > largest) {
          largest = push;
          change = i;
        }
      }
      if (change < 0) break;
      free[change] = !free[change];
    }
    // The pull to the starting angles, within the motions that leave the foot where it is:
    // there are such motions only while all seven hinges are free.
    pull->fill(0);
    if (std::all_of(free, free + kHinges, [](bool f) { return f; })) {
      Vec6 moved{};
      for (int i = 0; i < kHinges; ++i) {
        (*pull)[i] = kPull * (start_[i] - q[i]);
        for (int r = 0; r < 6; ++r) moved[r] += jac[r][i] * (*pull)[i];
      }
      Angles undo = DampedStep(jac, free, lambda, moved);
      for (int i = 0; i < kHinges; ++i) (*pull)[i] -= undo[i];
    }
    double largest = 0;
    for (int i = 0; i < kHinges; ++i) largest = std::max(largest, std::abs(step[i] + (*pull)[i]));
    double scale = largest > kMaxStep ? kMaxStep / largest : 1.0;
    for (int i = 0; i < kHinges; ++i) {
      (*task)[i] = scale * step[i];
      (*pull)[i] *= scale;
    }
  }

  const mjModel* m_;
  mjData* d_;
  int body_;
  Vec3 position_;
  Quat rotation_;
  int qadr_[kHinges], dadr_[kHinges];
  double lower_[kHinges], upper_[kHinges];
  Angles start_;
  std::vector<double> jacp_, jacr_;
};

}  // namespace

LegIkResult SolveLegIk(const Character& character, const std::string& side, const Vec3& position,
                       const Quat& rotation, double* qpos, mjData* scratch) {
  if (side != "right" && side != "left") {
    throw std::invalid_argument("leg side must be \"right\" or \"left\", got \"" + side + "\"");
  }
  DataPtr own;
  if (!scratch) {
    own = character.MakeData();
    scratch = own.get();
  }
  LegSolver solver(character, side, position, rotation, qpos, scratch);
  constexpr int kHipZ = 2, kKnee = 3;  // indices among the leg's hinges

  // Already there: nothing changes.
  LegSolver::Attempt best;
  solver.Error(solver.start(), &best);
  if (!best.converged()) {
    LegSolver::Angles q = solver.start();
    q[kKnee] = solver.Clamp(kKnee, std::max(q[kKnee], kMinStartKnee));
    int iterations = 0;
    best = solver.Run(q);
    iterations += best.result.iterations;
    for (const Restart& restart : kRestarts) {
      if (best.converged()) break;
      q = solver.start();
      q[kHipZ] = solver.Clamp(kHipZ, restart.hip_z);
      q[kKnee] = solver.Clamp(kKnee, restart.knee);
      LegSolver::Attempt again = solver.Run(q);
      iterations += again.result.iterations;
      if (again.total < best.total) best = again;
    }
    best.result.iterations = iterations;
  }
  for (int i = 0; i < kHinges; ++i) qpos[solver.qpos_address(i)] = best.q[i];
  return best.result;
}

}  // namespace ragdoll::motion
