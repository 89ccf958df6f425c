#include "cli/play_command.h"

#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "actor/rollout.h"
#include "common/config_section.h"
#include "render/renderer.h"
#include "run/trained_policy.h"
#include "sim/falls.h"
#include "sim/steering_task.h"

namespace ragdoll::cli {
namespace {

struct PlayOptions {
  std::string target;
  double seconds = 0;  // 0: until the window is closed
  std::string log;
  double push_impulse = 30;    // N s, horizontal, on the root (space; + and - change it)
  double push_duration = 0.2;  // s
  double knock_impulse = 150;  // N s, horizontal, on the chest (K), over 0.1 s
  double fall_pause = 1.0;     // s the fall stays on screen before the automatic reset
  std::string ghost = "none";
  render::View view;
  uint64_t seed = 1;
};

constexpr char kHelp[] =
    "W A S D / arrows: walk, back, strafe   Q E: turn   space: push   + -: push strength   "
    "K: knock down   R: reset   Esc: quit";

// The keys held down, and the one-shot keys pressed since they were last taken.
struct KeyState {
  std::set<int> held;
  bool push = false, knock = false, reset = false, quit = false;
  int stronger = 0;  // presses of + less presses of -

  void Handle(int key, bool pressed) {
    if (key == GLFW_KEY_UNKNOWN) return;
    if (pressed) {
      held.insert(key);
    } else {
      held.erase(key);
    }
    if (!pressed) return;
    push |= key == GLFW_KEY_SPACE;
    knock |= key == GLFW_KEY_K;
    stronger += key == GLFW_KEY_EQUAL || key == GLFW_KEY_KP_ADD;
    stronger -= key == GLFW_KEY_MINUS || key == GLFW_KEY_KP_SUBTRACT;
    reset |= key == GLFW_KEY_R;
    quit |= key == GLFW_KEY_ESCAPE;
  }
  bool Held(int key, int alternative = GLFW_KEY_UNKNOWN) const {
    return held.count(key) || held.count(alternative);
  }
};

// A unit command (1 m/s, 1 rad/s) in each held key's direction. MotionSet::Nearest then picks
// the set's clip for that direction; where the set has none (no walk_backward, say), standing is
// nearer than the clip going the other way, so the character stops.
sim::Command KeyCommand(const KeyState& keys) {
  sim::Command c;
  c.forward = keys.Held(GLFW_KEY_W, GLFW_KEY_UP) - keys.Held(GLFW_KEY_S, GLFW_KEY_DOWN);
  c.left = keys.Held(GLFW_KEY_A, GLFW_KEY_LEFT) - keys.Held(GLFW_KEY_D, GLFW_KEY_RIGHT);
  c.turn = keys.Held(GLFW_KEY_Q) - keys.Held(GLFW_KEY_E);
  return c;
}

double Degrees(double radians) { return radians * 180 / M_PI; }

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// --log FILE with its header line; none without the option.
std::unique_ptr<std::FILE, FileCloser> OpenLog(const std::string& path) {
  std::unique_ptr<std::FILE, FileCloser> log;
  if (path.empty()) return log;
  log.reset(std::fopen(path.c_str(), "w"));
  if (!log) throw ConfigError("play: --log " + path + ": cannot write the file");
  std::fprintf(log.get(),
               "time,wall,episode,command,reference,x,y,heading,desired_heading,vx,vy,"
               "speed_error,heading_error,fell,falls,getting_up,standing,pushed\n");
  return log;
}

// A session: one environment stepped by the trained policy in real time, steered by the keys,
// drawn when there is time.
class PlaySession {
 public:
  PlaySession(const PlayOptions& o, const run::TrainedPolicy& policy, const sim::EnvConfig& env)
      : o_(o),
        policy_version_(policy.version),
        dt_(env.control_dt()),
        push_ticks_total_(std::max(1, static_cast<int>(std::lround(o.push_duration / dt_)))),
        worker_(env, 1, 1, o.seed, "play"),
        e_(worker_.environment(0)),
        steering_(env.steering.enabled() ? &sim::Steering(e_) : nullptr),
        motions_(e_.motion_set()),
        model_(e_.character().model()),
        root_(e_.character().root_body()),
        chest_(std::max(root_, mj_name2id(model_, mjOBJ_BODY, "chest"))),
        stand_height_(sim::StandHeight(*motions_.entry(motions_.commands().front()).clip)),
        log_(OpenLog(o.log)),
        renderer_(model_, o.view, "ragdoll play: " + o.target,
                  [this](int key, bool pressed) { keys_.Handle(key, pressed); }),
        reference_(mj_makeData(model_)),
        reference_qvel_(model_->nv),
        rng_(o.seed),
        push_impulse_(o.push_impulse) {
    worker_.SetPolicy(policy.snapshot);
    command_ = motions_.commands().front();
    if (steering_) {
      command_ = motions_.Nearest(KeyCommand(keys_));
      worker_.SetCommandFirst(command_);
    }
    worker_.ResetFirst(uniform_(rng_));
  }

  // Runs until `stop`, Esc, the window's closing or --seconds; prints the summary.
  void Run(const std::atomic<bool>& stop) {
    // The first frame compiles OpenGL programs (half a second in software): the clock starts
    // after.
    Draw();
    start_ = Clock::now();
    // Said once the clock runs, so a script driving the window knows its keys will count.
    std::fprintf(stderr, "play: started\n");
    double due = 0;  // when the next control step is due, wall seconds from the start
    while (!stop.load() && !keys_.quit && renderer_.PollEvents()) {
      const double now = SecondsSince(start_);
      if (o_.seconds > 0 && now >= o_.seconds) break;
      if (now < due) {
        std::this_thread::sleep_for(std::chrono::duration<double>(due - now));
        continue;
      }
      if (now - due > kMaxLag) {
        lost_ += now - due;
        due = now;
      }
      ControlStep();
      due += dt_;
      MeasureWindow(now);
      // Draw only when the next step is not due yet: a late frame is skipped, not the simulation.
      if (SecondsSince(start_) < due) {
        Draw();
      } else {
        ++skipped_;
      }
    }
    PrintSummary(SecondsSince(start_));
  }

 private:
  // Further behind than this, the simulation stops catching up (it runs slower than real time
  // on this machine) rather than stepping in a burst the player would see as a jump.
  static constexpr double kMaxLag = 0.25;
  // How long a knock-down (K) pushes, s.
  static constexpr double kKnockSeconds = 0.1;

  void Reset() {
    worker_.ResetFirst(uniform_(rng_));
    ++episode_;
    push_ticks_ = 0;
    pause_left_ = 0;
    task_falls_ = 0;
    getting_up_ = false;
  }

  // One control step: the keys, then the simulation (or the fall still on screen).
  void ControlStep() {
    if (keys_.reset) Reset();
    keys_.reset = false;
    if (pause_left_ > 0) {
      pause_left_ -= dt_;
      if (pause_left_ <= 0) Reset();
    } else {
      Steer();
      Simulate();
    }
    keys_.push = keys_.knock = false;
    ++ticks_;
    ++window_ticks_;
  }

  // The command the held keys ask for, and a push when space was pressed.
  void Steer() {
    const int wanted = steering_ ? motions_.Nearest(KeyCommand(keys_)) : command_;
    if (wanted != command_) {
      command_ = wanted;
      worker_.SetCommandFirst(command_);
    }
    push_impulse_ = std::clamp(push_impulse_ + 10.0 * keys_.stronger, 0.0, 500.0);
    keys_.stronger = 0;
    if (keys_.push) Push(root_, push_impulse_, push_ticks_total_);
    if (keys_.knock) {
      Push(chest_, o_.knock_impulse,
           std::max(1, static_cast<int>(std::lround(kKnockSeconds / dt_))));
    }
  }

  // A horizontal push on `body` in a random direction: `impulse` N s spread over `ticks` steps.
  void Push(int body, double impulse, int ticks) {
    if (push_ticks_ > 0) e_.SetExternalForce(pushed_body_, {0, 0, 0});
    const double direction = 2 * M_PI * uniform_(rng_);
    const double force = impulse / (ticks * dt_);
    e_.SetExternalForce(body, {force * std::cos(direction), force * std::sin(direction), 0});
    push_angle_ = character::WrapAngle(direction - e_.heading());
    push_shown_ = impulse;
    pushed_now_ = impulse;
    pushed_body_ = body;
    push_ticks_ = ticks;
    ++pushes_;
  }

  // The policy's step, the push's end, the log line, and a fall's pause or a new episode.
  void Simulate() {
    const auto begin = Clock::now();
    const sim::StepResult r = worker_.StepFirst(true);
    step_seconds_ += SecondsSince(begin);
    ++steps_;
    if (push_ticks_ > 0 && --push_ticks_ == 0) e_.SetExternalForce(pushed_body_, {0, 0, 0});
    FollowRecovery();
    if (log_) LogStep(r);
    if (r.terminated) {
      ++falls_;
      std::fprintf(stderr, "play: fell (%s) after %.1f s; restarting\n",
                   sim::EpisodeEndName(e_.episode().end), e_.episode().length * dt_);
      pause_left_ = o_.fall_pause;
      push_ticks_ = 0;
      if (pause_left_ <= 0) Reset();
    } else if (r.truncated) {
      Reset();
    }
  }

  // With recovery (environment.recovery) a fall does not end the episode: the character gets
  // up. Says when it fell and when it stood again.
  void FollowRecovery() {
    const double now = (ticks_ + 1) * dt_;
    if (e_.episode().task_falls > task_falls_) {
      task_falls_ = e_.episode().task_falls;
      ++falls_;
      fell_at_ = now;
      std::fprintf(stderr, "play: fell at %.1f s; getting up\n", now);
    }
    const bool getting_up = motions_.entry(e_.reference_entry()).get_up;
    if (getting_up_ && !getting_up) {
      std::fprintf(stderr, "play: up again at %.1f s, %.1f s after the fall\n", now,
                   now - fell_at_);
    }
    getting_up_ = getting_up;
  }

  // The travel velocity steering measures, or the root's without steering, m/s.
  character::Vec3 Velocity() const {
    if (steering_) return steering_->TravelVelocity();
    return {e_.data().qvel[0], e_.data().qvel[1], 0};
  }
  double DesiredHeading() const { return steering_ ? steering_->desired_heading() : e_.heading(); }

  void LogStep(const sim::StepResult& r) {
    const character::Vec3 v = Velocity();
    const bool standing =
        sim::PostureOf(e_.character(), e_.data(), stand_height_) == sim::Posture::kStanding;
    std::fprintf(
        log_.get(), "%.4f,%.4f,%d,%s,%s,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%d,%d,%d,%d,%.0f\n",
        (ticks_ + 1) * dt_, SecondsSince(start_), episode_, motions_.entry(command_).name.c_str(),
        motions_.entry(e_.reference_entry()).name.c_str(), e_.data().qpos[0], e_.data().qpos[1],
        e_.heading(), DesiredHeading(), v[0], v[1], steering_ ? steering_->SpeedError() : 0.0,
        steering_ ? steering_->HeadingError(e_) : 0.0, r.terminated ? 1 : 0,
        e_.episode().task_falls, getting_up_ ? 1 : 0, standing ? 1 : 0, pushed_now_);
    pushed_now_ = 0;
  }

  // The heads-up figures, over the last second.
  void MeasureWindow(double now) {
    if (now - window_start_ < 1.0) return;
    fps_ = window_frames_ / (now - window_start_);
    realtime_ = window_ticks_ * dt_ / (now - window_start_);
    window_start_ = now;
    window_frames_ = window_ticks_ = 0;
  }

  std::string Hud() const {
    const character::Vec3 v = Velocity();
    std::string name = motions_.entry(command_).name;
    const std::string& clip = motions_.entry(e_.reference_entry()).name;
    if (clip != name) name += " via " + clip;  // a transition clip plays
    char text[512];
    std::snprintf(text, sizeof(text),
                  "command %s\nspeed %.2f m/s\nheading %.0f deg, desired %.0f deg\npolicy v%lld",
                  name.c_str(), std::hypot(v[0], v[1]), Degrees(e_.heading()),
                  Degrees(DesiredHeading()), static_cast<long long>(policy_version_));
    std::string caption = text;
    if (window_start_ > 0) {  // measured over a second at least
      std::snprintf(text, sizeof(text), "\n%.0f fps, real time x%.2f", fps_, realtime_);
      caption += text;
    }
    std::snprintf(text, sizeof(text), "\nspace pushes %.0f N s (+ -)", push_impulse_);
    caption += text;
    if (pause_left_ > 0) {
      caption += "\nfell: restarting";
    } else if (getting_up_) {
      caption += "\ngetting up";
    }
    if (push_ticks_ > 0) {
      std::snprintf(text, sizeof(text), "\npushed %.0f N s at %+.0f deg from facing", push_shown_,
                    Degrees(push_angle_));
      caption += text;
    }
    return caption;
  }

  void Draw() {
    const mjData* ghost = nullptr;
    if (o_.ghost == "overlay") {
      e_.ReferenceState(e_.time(), reference_->qpos, reference_qvel_.data());
      mj_kinematics(model_, reference_.get());
      ghost = reference_.get();
    }
    const auto begin = Clock::now();
    renderer_.Draw(e_.data(), ghost, Hud(), kHelp);
    draw_seconds_ += SecondsSince(begin);
    ++frames_;
    ++window_frames_;
  }

  void PrintSummary(double wall) const {
    std::fprintf(stderr,
                 "play: %.1f s in %.1f s: real-time factor %.2f, %.1f frames/s (%lld skipped), "
                 "%lld control steps (%.1f ms each), %.1f ms a frame, %d fall%s, %d push%s, "
                 "%.1f s lost behind real time\n",
                 ticks_ * dt_, wall, ticks_ * dt_ / std::max(wall, 1e-9),
                 frames_ / std::max(wall, 1e-9), static_cast<long long>(skipped_),
                 static_cast<long long>(steps_),
                 1000 * step_seconds_ / std::max<int64_t>(steps_, 1),
                 1000 * draw_seconds_ / std::max<int64_t>(frames_, 1), falls_,
                 falls_ == 1 ? "" : "s", pushes_, pushes_ == 1 ? "" : "es", lost_);
  }

  const PlayOptions& o_;
  const int64_t policy_version_;
  const double dt_;
  const int push_ticks_total_;
  actor::RolloutWorker worker_;
  sim::ImitationEnv& e_;
  const sim::SteeringTask* steering_;  // none: the keys only push and knock down
  const sim::MotionSet& motions_;
  const mjModel* model_;
  const int root_, chest_;
  const double stand_height_;  // m: standing is the pelvis above it (sim::PostureOf)
  std::unique_ptr<std::FILE, FileCloser> log_;
  KeyState keys_;
  render::Renderer renderer_;
  character::DataPtr reference_;
  std::vector<double> reference_qvel_;
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
  Clock::time_point start_;

  int command_ = 0;
  int episode_ = 0, push_ticks_ = 0, falls_ = 0, pushes_ = 0;
  double push_impulse_;    // N s of a push (space)
  double push_shown_ = 0;  // N s of the current push or knock
  double pushed_now_ = 0;  // N s of a push or knock started this step, for the log
  int pushed_body_ = 0;
  double push_angle_ = 0;  // of the current push, from the character's facing, radians
  int task_falls_ = 0;     // falls the recovery task saw this episode
  bool getting_up_ = false;
  double fell_at_ = 0;     // s
  double pause_left_ = 0;  // s of the fall still to show
  int64_t ticks_ = 0, steps_ = 0, frames_ = 0, skipped_ = 0;
  double lost_ = 0;                             // wall seconds the simulation fell behind for good
  double step_seconds_ = 0, draw_seconds_ = 0;  // spent stepping and drawing, for the summary
  double window_start_ = 0, fps_ = 0, realtime_ = 0;
  int64_t window_frames_ = 0, window_ticks_ = 0;
};

int Play(const PlayOptions& o, const std::atomic<bool>& stop) {
  run::TrainedPolicy policy = run::LoadTrainedPolicy(o.target);
  sim::EnvConfig env = policy.experiment.environment;
  if (!env.steering.enabled()) {
    std::fprintf(stderr,
                 "play: %s has no steering task (environment.steering): it follows its clip; "
                 "space pushes, K knocks it down\n",
                 policy.checkpoint.c_str());
  }
  // A player walks for as long as they like: no time limit cuts the episode short.
  env.max_episode_steps = 1'000'000'000;
  // Real time on one core: the policy's forward pass on this thread only.
  actor::SetPolicyThreads(1);
  PlaySession session(o, policy, env);
  session.Run(stop);
  return 0;
}

}  // namespace

std::function<int()> AddPlayCommand(CLI::App& app, const std::atomic<bool>& stop) {
  auto o = std::make_shared<PlayOptions>();
  auto* cmd = app.add_subcommand(
      "play",
      "steer a trained run with the keyboard (a steering run), push it and knock it down, in a "
      "window, in real time");
  cmd->add_option("run_or_checkpoint", o->target, "runs/<id> or a checkpoint")->required();
  cmd->add_option("--seconds", o->seconds, "quit after this many seconds (default: on Esc)");
  cmd->add_option("--log", o->log,
                  "CSV, one line per control step: time, command, reference clip, root x y (m), "
                  "heading and desired heading (rad), travel velocity (m/s), errors, fell");
  cmd->add_option("--push-impulse", o->push_impulse,
                  "space: a horizontal push on the root in a random direction, N s (+ and - "
                  "change it by 10)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--push-duration", o->push_duration, "how long a push lasts, s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--knock-impulse", o->knock_impulse,
                  "K: a hard horizontal push on the chest in a random direction, N s over 0.1 s")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--fall-pause", o->fall_pause, "a fall stays on screen this long, s")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--ghost", o->ghost, "the reference clip overlaid as a ghost, or none")
      ->check(CLI::IsMember({"none", "overlay"}))
      ->capture_default_str();
  cmd->add_option("--width", o->view.width)->capture_default_str()->check(CLI::Range(64, 3840));
  cmd->add_option("--height", o->view.height)->capture_default_str()->check(CLI::Range(64, 2160));
  cmd->add_option("--seed", o->seed, "start phases and push directions")->capture_default_str();
  return [=, &stop]() -> int {
    if (!*cmd) return -1;
    return Play(*o, stop);
  };
}

}  // namespace ragdoll::cli
