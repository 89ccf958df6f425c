#include "cli/play_command.h"

#include <ATen/Parallel.h>
#include <GLFW/glfw3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "actor/render/renderer.h"
#include "actor/rollout.h"
#include "actor/sim/steering_task.h"
#include "cli/trained_policy.h"
#include "common/config_section.h"

namespace ragdoll::cli {
namespace {

struct PlayOptions {
  std::string target;
  double seconds = 0;  // 0: until the window is closed
  std::string log;
  double push_force = 150;     // N, horizontal, on the root
  double push_duration = 0.2;  // s
  double fall_pause = 1.0;     // s the fall stays on screen before the automatic reset
  std::string ghost = "none";
  render::View view;
  uint64_t seed = 1;
};

constexpr char kHelp[] =
    "W A S D / arrows: walk, back, strafe   Q E: turn   space: push   R: reset   Esc: quit";

// The keys held down, and the one-shot keys pressed since they were last taken.
struct KeyState {
  std::set<int> held;
  bool push = false, reset = false, quit = false;

  void Handle(int key, bool pressed) {
    if (key == GLFW_KEY_UNKNOWN) return;
    if (pressed) {
      held.insert(key);
    } else {
      held.erase(key);
    }
    if (!pressed) return;
    push |= key == GLFW_KEY_SPACE;
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

int Play(const PlayOptions& o, const std::atomic<bool>& stop) {
  using Clock = std::chrono::steady_clock;
  TrainedPolicy policy = LoadTrainedPolicy(o.target);
  sim::EnvConfig env = policy.experiment.environment;
  if (!env.steering.enabled()) {
    throw ConfigError("play: " + policy.checkpoint +
                      " was not trained with a steering task (environment.steering); "
                      "`ragdoll render` shows other runs");
  }
  // A player walks for as long as they like: no time limit cuts the episode short.
  env.max_episode_steps = 1'000'000'000;
  // Real time on one core: the policy's forward pass on this thread only.
  at::set_num_threads(1);

  actor::RolloutWorker worker(env, 1, 1, o.seed, "play");
  worker.SetPolicy(policy.snapshot);
  sim::ImitationEnv& e = worker.environment(0);
  const sim::SteeringTask& steering = sim::Steering(e);
  const sim::MotionSet& motions = e.motion_set();
  const mjModel* model = e.character().model();
  const int root = e.character().root_body();

  std::unique_ptr<std::FILE, FileCloser> log;
  if (!o.log.empty()) {
    log.reset(std::fopen(o.log.c_str(), "w"));
    if (!log) throw ConfigError("play: --log " + o.log + ": cannot write the file");
    std::fprintf(log.get(),
                 "time,wall,episode,command,reference,x,y,heading,desired_heading,vx,vy,"
                 "speed_error,heading_error,fell\n");
  }

  KeyState keys;
  render::Renderer renderer(model, o.view, "ragdoll play: " + o.target,
                            [&keys](int key, bool pressed) { keys.Handle(key, pressed); });
  sim::DataPtr reference(mj_makeData(model));
  std::vector<double> reference_qvel(model->nv);

  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  int command = motions.Nearest(KeyCommand(keys));
  worker.SetCommandFirst(command);
  worker.ResetFirst(uniform(rng));

  const double dt = env.control_dt();
  const int push_ticks_total = std::max(1, static_cast<int>(std::lround(o.push_duration / dt)));
  // Further behind than this, the simulation stops catching up (it runs slower than real time
  // on this machine) rather than stepping in a burst the player would see as a jump.
  const double max_lag = 0.25;
  int episode = 0, push_ticks = 0, falls = 0, pushes = 0;
  double push_angle = 0;  // of the current push, from the character's facing, radians
  double pause_left = 0;  // s of the fall still to show
  int64_t ticks = 0, steps = 0, frames = 0, skipped = 0;
  double lost = 0;                            // wall seconds the simulation fell behind for good
  double step_seconds = 0, draw_seconds = 0;  // spent stepping and drawing, for the summary
  // The heads-up figures, over the last second.
  double window_start = 0, fps = 0, realtime = 0;
  int64_t window_frames = 0, window_ticks = 0;

  auto reset = [&] {
    worker.ResetFirst(uniform(rng));
    ++episode;
    push_ticks = 0;
    pause_left = 0;
  };
  auto hud = [&] {
    const sim::Vec3 v = steering.TravelVelocity();
    std::string name = motions.entry(command).name;
    const std::string& clip = motions.entry(e.reference_entry()).name;
    if (clip != name) name += " via " + clip;  // a transition clip plays
    char text[512];
    std::snprintf(text, sizeof(text),
                  "command %s\nspeed %.2f m/s\nheading %.0f deg, desired %.0f deg\npolicy v%lld",
                  name.c_str(), std::hypot(v[0], v[1]), Degrees(e.heading()),
                  Degrees(steering.desired_heading()), static_cast<long long>(policy.version));
    std::string caption = text;
    if (window_start > 0) {  // measured over a second at least
      std::snprintf(text, sizeof(text), "\n%.0f fps, real time x%.2f", fps, realtime);
      caption += text;
    }
    if (pause_left > 0) {
      caption += "\nfell: restarting";
    } else if (push_ticks > 0) {
      std::snprintf(text, sizeof(text), "\npush %.0f N at %+.0f deg from facing", o.push_force,
                    Degrees(push_angle));
      caption += text;
    }
    return caption;
  };
  auto draw = [&] {
    const mjData* ghost = nullptr;
    if (o.ghost == "overlay") {
      e.ReferenceState(e.time(), reference->qpos, reference_qvel.data());
      mj_kinematics(model, reference.get());
      ghost = reference.get();
    }
    const auto begin = Clock::now();
    renderer.Draw(e.data(), ghost, hud(), kHelp);
    draw_seconds += std::chrono::duration<double>(Clock::now() - begin).count();
    ++frames;
    ++window_frames;
  };

  // The first frame compiles OpenGL programs (half a second in software): the clock starts after.
  draw();
  const auto start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  double due = 0;  // when the next control step is due, wall seconds from the start
  while (!stop.load() && !keys.quit && renderer.PollEvents()) {
    const double now = elapsed();
    if (o.seconds > 0 && now >= o.seconds) break;
    if (now < due) {
      std::this_thread::sleep_for(std::chrono::duration<double>(due - now));
      continue;
    }
    if (now - due > max_lag) {
      lost += now - due;
      due = now;
    }

    // One control step: the keys, then the simulation (or the fall still on screen).
    if (keys.reset) reset();
    keys.reset = false;
    if (pause_left > 0) {
      pause_left -= dt;
      if (pause_left <= 0) reset();
    } else {
      const int wanted = motions.Nearest(KeyCommand(keys));
      if (wanted != command) {
        command = wanted;
        worker.SetCommandFirst(command);
      }
      if (keys.push) {
        const double direction = 2 * M_PI * uniform(rng);
        e.SetExternalForce(
            root, {o.push_force * std::cos(direction), o.push_force * std::sin(direction), 0});
        push_angle = sim::WrapAngle(direction - e.heading());
        push_ticks = push_ticks_total;
        ++pushes;
      }
      const auto begin = Clock::now();
      const sim::StepResult r = worker.StepFirst(true);
      step_seconds += std::chrono::duration<double>(Clock::now() - begin).count();
      ++steps;
      if (push_ticks > 0 && --push_ticks == 0) e.SetExternalForce(root, {0, 0, 0});
      if (log) {
        const sim::Vec3 v = steering.TravelVelocity();
        std::fprintf(log.get(), "%.4f,%.4f,%d,%s,%s,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%d\n",
                     (ticks + 1) * dt, elapsed(), episode, motions.entry(command).name.c_str(),
                     motions.entry(e.reference_entry()).name.c_str(), e.data().qpos[0],
                     e.data().qpos[1], e.heading(), steering.desired_heading(), v[0], v[1],
                     steering.SpeedError(), steering.HeadingError(e), r.terminated ? 1 : 0);
      }
      if (r.terminated) {
        ++falls;
        std::fprintf(stderr, "play: fell (%s) after %.1f s; restarting\n",
                     sim::EpisodeEndName(e.episode().end), steering.episode_time());
        pause_left = o.fall_pause;
        push_ticks = 0;
        if (pause_left <= 0) reset();
      } else if (r.truncated) {
        reset();
      }
    }
    keys.push = false;
    ++ticks;
    ++window_ticks;
    due += dt;

    if (now - window_start >= 1.0) {
      fps = window_frames / (now - window_start);
      realtime = window_ticks * dt / (now - window_start);
      window_start = now;
      window_frames = window_ticks = 0;
    }
    // Draw only when the next step is not due yet: a late frame is skipped, not the simulation.
    if (elapsed() < due) {
      draw();
    } else {
      ++skipped;
    }
  }

  const double wall = elapsed();
  std::fprintf(stderr,
               "play: %.1f s in %.1f s: real-time factor %.2f, %.1f frames/s (%lld skipped), "
               "%lld control steps (%.1f ms each), %.1f ms a frame, %d fall%s, %d push%s, %.1f s "
               "lost behind real time\n",
               ticks * dt, wall, ticks * dt / std::max(wall, 1e-9), frames / std::max(wall, 1e-9),
               static_cast<long long>(skipped), static_cast<long long>(steps),
               1000 * step_seconds / std::max<int64_t>(steps, 1),
               1000 * draw_seconds / std::max<int64_t>(frames, 1), falls, falls == 1 ? "" : "s",
               pushes, pushes == 1 ? "" : "es", lost);
  return 0;
}

}  // namespace

std::function<int()> AddPlayCommand(CLI::App& app, const std::atomic<bool>& stop) {
  auto o = std::make_shared<PlayOptions>();
  auto* cmd = app.add_subcommand(
      "play", "steer a trained steering run with the keyboard, in a window, in real time");
  cmd->add_option("run_or_checkpoint", o->target, "runs/<id> or a checkpoint")->required();
  cmd->add_option("--seconds", o->seconds, "quit after this many seconds (default: on Esc)");
  cmd->add_option("--log", o->log,
                  "CSV, one line per control step: time, command, reference clip, root x y (m), "
                  "heading and desired heading (rad), travel velocity (m/s), errors, fell");
  cmd->add_option("--push-force", o->push_force,
                  "space: a horizontal push on the root in a random direction, N")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--push-duration", o->push_duration, "how long a push lasts, s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
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
