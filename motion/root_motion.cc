#include "motion/root_motion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "motion/foot_geometry.h"

namespace ragdoll::motion {

using character::Character;
using character::MotionClip;
using character::Pose;
using character::Vec3;

namespace {

constexpr const char* kFeet[2] = {"right_ankle", "left_ankle"};
// A foot's floor is its lowest height over the clip, ignoring this fraction of frames (captures
// push a foot through the floor for a frame or two).
constexpr double kLowQuantile = 0.1;
// A weight-bearing foot's lowest point moves up or down slower than this.
constexpr double kSettledSpeed = 0.3;  // m/s

double Horizontal(const Vec3& v) { return std::hypot(v[0], v[1]); }
double Median3(double a, double b, double c) {
  return std::max(std::min(a, b), std::min(std::max(a, b), c));
}
double HeadingDegrees(const Vec3& v) { return std::atan2(v[1], v[0]) * 180 / M_PI; }

// Every sole corner of one foot in world coordinates, frame by frame.
struct SoleTrack {
  std::vector<std::vector<Vec3>> corners;  // [frame][corner]
  std::vector<double> lowest;              // [frame]
  double floor = 0;
};

struct ClipTrack {
  std::array<SoleTrack, 2> soles;
  std::vector<Vec3> com;  // [frame] the whole body's centre of mass, world
};

ClipTrack TrackClip(const MotionClip& clip, const Character& character) {
  const mjModel* m = character.model();
  character::DataPtr d = character.MakeData();
  const int n = clip.num_frames();
  ClipTrack track;
  std::array<SoleTrack, 2>& soles = track.soles;
  track.com.resize(n);
  int body[2];
  std::vector<Vec3> local[2];
  for (int s = 0; s < 2; ++s) {
    body[s] = character.BodyId(kFeet[s]);
    local[s] = FootCorners(m, body[s]);
    if (local[s].empty()) {
      throw std::invalid_argument(std::string("root motion: the character's ") + kFeet[s] +
                                  " body has no box geom (the sole)");
    }
    soles[s].corners.assign(n, std::vector<Vec3>(local[s].size()));
    soles[s].lowest.assign(n, INFINITY);
  }
  for (int f = 0; f < n; ++f) {
    character.PoseToQpos(clip.frame(f), d->qpos);
    mj_kinematics(m, d.get());
    mj_comPos(m, d.get());
    for (int i = 0; i < 3; ++i) track.com[f][i] = d->subtree_com[3 * 1 + i];
    for (int s = 0; s < 2; ++s) {
      const double* pos = d->xpos + 3 * body[s];
      const double* mat = d->xmat + 9 * body[s];
      for (size_t c = 0; c < local[s].size(); ++c) {
        Vec3& w = soles[s].corners[f][c];
        for (int i = 0; i < 3; ++i) {
          w[i] = pos[i] + mat[3 * i] * local[s][c][0] + mat[3 * i + 1] * local[s][c][1] +
                 mat[3 * i + 2] * local[s][c][2];
        }
        soles[s].lowest[f] = std::min(soles[s].lowest[f], w[2]);
      }
    }
  }
  for (SoleTrack& sole : soles) {
    std::vector<double> heights = sole.lowest;
    std::sort(heights.begin(), heights.end());
    sole.floor = heights[static_cast<size_t>(kLowQuantile * (n - 1))];
  }
  return track;
}

// Whether a foot bears weight over interval f -> f + 1 (its lowest point within `plant_height`
// of its floor at both ends, neither coming down nor lifting off fast) and, if so, the root's
// horizontal velocity it implies: minus the velocity of its contact corner (the corner touching
// the floor at the interval's start, which a rolling foot pivots on), which a weight-bearing
// foot keeps still.
bool FootImpliedVelocity(const SoleTrack& sole, int f, double dt, double plant_height,
                         Vec3* velocity, double* above) {
  *above = std::max(sole.lowest[f], sole.lowest[f + 1]) - sole.floor;
  if (*above > plant_height) return false;
  if (std::fabs(sole.lowest[f + 1] - sole.lowest[f]) > kSettledSpeed * dt) return false;
  const auto& now = sole.corners[f];
  size_t contact = 0;
  for (size_t c = 1; c < now.size(); ++c) {
    if (now[c][2] < now[contact][2]) contact = c;
  }
  *velocity = {-(sole.corners[f + 1][contact][0] - now[contact][0]) / dt,
               -(sole.corners[f + 1][contact][1] - now[contact][1]) / dt, 0};
  return true;
}

// The root's horizontal velocity over each interval as a weight-bearing foot implies it, and
// whether a foot bears weight there at all.
struct FootSupport {
  std::vector<Vec3> velocity;   // [interval]
  std::vector<bool> supported;  // [interval]
};

FootSupport TrackSupport(const MotionClip& clip, const ClipTrack& track, double plant_height) {
  const int intervals = clip.num_frames() - 1;
  FootSupport support;
  std::vector<Vec3>& velocity = support.velocity;
  std::vector<bool>& supported = support.supported;
  velocity.assign(intervals, {0, 0, 0});
  supported.assign(intervals, false);
  // One foot carries the estimate at a time: the one already bearing weight keeps it while it
  // stays down, so that in double support a foot still landing (its heel sliding onto the
  // floor) does not blend in. A looping clip's first intervals follow on from its last.
  int carrier = -1;
  for (int pass = clip.loop() ? 0 : 1; pass < 2; ++pass) {
    for (int f = 0; f < intervals; ++f) {
      const double dt = clip.frame_duration(f);
      bool down[2];
      Vec3 implied[2];
      double above[2];
      for (int s = 0; s < 2; ++s) {
        down[s] = FootImpliedVelocity(track.soles[s], f, dt, plant_height, &implied[s], &above[s]);
      }
      if (carrier < 0 || !down[carrier]) {
        carrier = down[0] && (!down[1] || above[0] <= above[1]) ? 0 : down[1] ? 1 : -1;
      }
      supported[f] = carrier >= 0;
      if (supported[f]) velocity[f] = implied[carrier];
    }
  }
  return support;
}

// How the planted feet slide, and whether that makes the clip one captured in place (the report's
// slide figures and in_place). Returns the time some foot bears weight, s.
double MeasureSlide(const MotionClip& clip, const FootSupport& support,
                    const RootMotionOptions& options, RootMotionReport& r) {
  const int intervals = clip.num_frames() - 1;
  const std::vector<Vec3>& velocity = support.velocity;
  const std::vector<bool>& supported = support.supported;
  double support_time = 0, speed_sum = 0;
  Vec3 slide_sum = {0, 0, 0};
  for (int f = 0; f < intervals; ++f) {
    if (!supported[f]) continue;
    const double dt = clip.frame_duration(f);
    support_time += dt;
    speed_sum += Horizontal(velocity[f]) * dt;
    for (int i = 0; i < 2; ++i) slide_sum[i] -= velocity[f][i] * dt;
  }
  r.support_fraction = support_time / clip.duration();
  if (support_time > 0) {
    r.slide_velocity = {slide_sum[0] / support_time, slide_sum[1] / support_time, 0};
    r.slide_coherence = speed_sum > 0 ? Horizontal(slide_sum) / speed_sum : 0;
  }
  const double slide = Horizontal(r.slide_velocity);
  r.in_place = slide >= options.min_slide_speed && r.slide_coherence >= options.min_coherence &&
               r.support_fraction >= options.min_support &&
               r.root_speed <= options.max_root_ratio * slide;
  return support_time;
}

// A single interval far from both supported neighbours is a glitch of the capture (a foot
// rotation flipping for a frame): the neighbours' median replaces it.
void RemoveGlitches(const MotionClip& clip, FootSupport& support) {
  const int intervals = clip.num_frames() - 1;
  std::vector<Vec3>& velocity = support.velocity;
  const std::vector<bool>& supported = support.supported;
  const std::vector<Vec3> raw = velocity;
  auto neighbour = [&](int f, int step) {
    const int g = f + step;
    if (!clip.loop() && (g < 0 || g >= intervals)) return -1;
    const int w = (g + intervals) % intervals;
    return supported[w] ? w : -1;
  };
  for (int f = 0; f < intervals; ++f) {
    const int a = neighbour(f, -1), b = neighbour(f, 1);
    if (!supported[f] || a < 0 || b < 0) continue;
    for (int i = 0; i < 2; ++i) velocity[f][i] = Median3(raw[a][i], raw[f][i], raw[b][i]);
  }
}

// The clip's own centre-of-mass velocity, with single-interval glitches (a foot pushed
// through the floor for a frame) replaced by the median of the interval and its neighbours.
std::vector<Vec3> OwnComVelocity(const MotionClip& clip, const ClipTrack& track) {
  const int intervals = clip.num_frames() - 1;
  std::vector<Vec3> com_raw(intervals), own(intervals);
  for (int f = 0; f < intervals; ++f) {
    for (int i = 0; i < 2; ++i) {
      com_raw[f][i] = (track.com[f + 1][i] - track.com[f][i]) / clip.frame_duration(f);
    }
    com_raw[f][2] = 0;
  }
  for (int f = 0; f < intervals; ++f) {
    const bool ends = !clip.loop() && (f == 0 || f + 1 == intervals);
    const Vec3& a = com_raw[(f - 1 + intervals) % intervals];
    const Vec3& b = com_raw[(f + 1) % intervals];
    own[f] = ends ? com_raw[f]
                  : Vec3{Median3(a[0], com_raw[f][0], b[0]), Median3(a[1], com_raw[f][1], b[1]), 0};
  }
  return own;
}

// Where no foot bears weight (a run's flight) the body is ballistic: its centre of mass moves
// at a constant horizontal velocity. The root's velocity there is the centre of mass's,
// interpolated between the supported intervals around the gap (whose true centre-of-mass
// velocity is the root's plus the clip's own centre-of-mass motion), less the clip's own.
std::vector<Vec3> FillFlights(const MotionClip& clip, const FootSupport& support,
                              const std::vector<Vec3>& own) {
  const int intervals = clip.num_frames() - 1;
  const std::vector<Vec3>& velocity = support.velocity;
  const std::vector<bool>& supported = support.supported;
  std::vector<Vec3> filled = velocity;
  for (int f = 0; f < intervals; ++f) {
    if (supported[f]) continue;
    // Nearest supported intervals each way, and how many intervals away (frames are evenly
    // spaced in every format read).
    int before = -1, after = -1, to_before = 0, to_after = 0;
    for (int k = 1; k < intervals && before < 0; ++k) {
      if (f - k < 0 && !clip.loop()) break;
      const int g = (f - k + intervals) % intervals;
      if (supported[g]) before = g, to_before = k;
    }
    for (int k = 1; k < intervals && after < 0; ++k) {
      if (f + k >= intervals && !clip.loop()) break;
      const int g = (f + k) % intervals;
      if (supported[g]) after = g, to_after = k;
    }
    if (before < 0) before = after;
    if (after < 0) after = before;
    const double alpha =
        to_before + to_after > 0 ? static_cast<double>(to_before) / (to_before + to_after) : 0.5;
    for (int i = 0; i < 2; ++i) {
      const double com = (1 - alpha) * (velocity[before][i] + own[before][i]) +
                         alpha * (velocity[after][i] + own[after][i]);
      filled[f][i] = com - own[f][i];
    }
  }
  return filled;
}

// The clip with its root moved on at `filled` (the root's velocity per interval), and the travel
// that added.
MotionClip MoveRoot(const MotionClip& clip, const std::vector<Vec3>& filled, RootMotionReport& r) {
  const int n = clip.num_frames();
  const int intervals = n - 1;
  std::vector<Pose> frames(n);
  std::vector<double> durations(n);
  Vec3 offset = {0, 0, 0};
  for (int f = 0; f < n; ++f) {
    frames[f] = clip.frame(f);
    durations[f] = clip.frame_duration(f);
    for (int i = 0; i < 2; ++i) frames[f].root_position[i] += offset[i];
    if (f < intervals) {
      for (int i = 0; i < 2; ++i) offset[i] += filled[f][i] * durations[f];
    }
  }
  r.reconstructed = true;
  for (int i = 0; i < 2; ++i) {
    r.added_travel[i] = frames[n - 1].root_position[i] - clip.frame(n - 1).root_position[i];
  }
  return MotionClip(clip.name(), clip.loop(), std::move(durations), std::move(frames),
                    clip.cycle_transform());
}

}  // namespace

RootMotion ParseRootMotion(const std::string& text) {
  if (text == "auto") return RootMotion::kAuto;
  if (text == "feet") return RootMotion::kFeet;
  if (text == "keep") return RootMotion::kKeep;
  throw std::invalid_argument("root motion: '" + text + "' is not one of auto, feet, keep");
}

std::string RootMotionReport::Summary() const {
  char line[400];
  const double slide = Horizontal(slide_velocity);
  if (reconstructed) {
    std::snprintf(line, sizeof(line),
                  "root motion: %s: the planted feet slide at %.2f m/s toward %.0f deg (%.0f %% "
                  "coherent, %.0f %% of the time) while the root travels %.2f m/s; rebuilt from "
                  "the feet: %.2f m toward %.0f deg over the clip (--root-motion keep: as it came)",
                  in_place ? "in place" : "from the feet (--root-motion feet)", slide,
                  HeadingDegrees(slide_velocity), 100 * slide_coherence, 100 * support_fraction,
                  root_speed, Horizontal(added_travel), HeadingDegrees(added_travel));
  } else {
    std::snprintf(line, sizeof(line),
                  "root motion: kept: the root travels %.2f m/s; the planted feet slide at %.2f "
                  "m/s (%.0f %% coherent, %.0f %% of the time)%s",
                  root_speed, slide, 100 * slide_coherence, 100 * support_fraction,
                  support_fraction == 0 ? ": no foot bears weight" : "");
  }
  return line;
}

MotionClip ReconstructRootMotion(const MotionClip& clip, const Character& character,
                                 RootMotion mode, RootMotionReport* report,
                                 const RootMotionOptions& options) {
  RootMotionReport local;
  RootMotionReport& r = report ? *report : local;
  r = RootMotionReport{};
  const int n = clip.num_frames();
  const Vec3 first = clip.frame(0).root_position, last = clip.frame(n - 1).root_position;
  r.root_speed = Horizontal({last[0] - first[0], last[1] - first[1], 0}) / clip.duration();
  if (mode == RootMotion::kKeep) return clip;

  const ClipTrack track = TrackClip(clip, character);
  FootSupport support = TrackSupport(clip, track, options.plant_height);
  const double support_time = MeasureSlide(clip, support, options, r);
  if (support_time == 0 || (mode == RootMotion::kAuto && !r.in_place)) return clip;

  RemoveGlitches(clip, support);
  const std::vector<Vec3> own = OwnComVelocity(clip, track);
  return MoveRoot(clip, FillFlights(clip, support, own), r);
}

}  // namespace ragdoll::motion
