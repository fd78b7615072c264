// The peer programs' side of vadop's trajectory file: reads the detect-mode paths one frame at a
// time, answers where a body is at any instant of the frame, and records and reports what a
// pipeline found. Owns the file format (written by crates/vadop-bench/src/peers/trajectory.rs;
// keep the two in step) and the timing and memory report, so every library is measured the same
// way. The mixed-shape scene's file is shapes.h's; peer_main tells the two apart.
//
// File (little-endian): "VADOPTR1", n u64, frames u64, dt f64, radius f64, box min 3 f64, box
// max 3 f64; then per frame: n x (position 3 f64, velocity 3 f64) at the frame start, n x
// position 3 f64 at the frame end, a bounce count u64 and that many (body u64, time since the
// frame start f64, position 3 f64), sorted by body then time. A body's path within a frame is the
// polyline through its start, its wall bounces and its end.
#pragma once
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>
#include "shapes.h"

struct Knot {
  double tau;
  double p[3];
};

class Trajectory {
 public:
  uint64_t n = 0, frames = 0;
  double dt = 0, radius = 0, box_min[3], box_max[3];

  explicit Trajectory(const char* path) : file_(std::fopen(path, "rb")) {
    if (!file_) throw std::runtime_error(std::string("cannot open ") + path);
    char magic[8];
    read(magic, 8);
    if (std::memcmp(magic, "VADOPTR1", 8) != 0) throw std::runtime_error("not a vadop trajectory file");
    read(&n, 8);
    read(&frames, 8);
    read(&dt, 8);
    read(&radius, 8);
    read(box_min, 24);
    read(box_max, 24);
    start_.resize(n * 6);
    end_.resize(n * 3);
    first_bounce_.resize(n + 1);
  }
  ~Trajectory() { std::fclose(file_); }

  // Loads the next frame; false after the last.
  bool next_frame() {
    if (frame_ == frames) return false;
    read(start_.data(), start_.size() * 8);
    read(end_.data(), end_.size() * 8);
    uint64_t count;
    read(&count, 8);
    bounces_.resize(count);
    std::fill(first_bounce_.begin(), first_bounce_.end(), 0);
    for (uint64_t k = 0; k < count; ++k) {
      uint64_t body;
      read(&body, 8);
      read(&bounces_[k], sizeof(Knot));
      ++first_bounce_[body + 1];
    }
    for (uint64_t i = 0; i < n; ++i) first_bounce_[i + 1] += first_bounce_[i];
    ++frame_;
    return true;
  }
  // Index of the frame loaded by the last next_frame().
  uint32_t frame() const { return uint32_t(frame_ - 1); }

  const double* start(uint64_t i) const { return &start_[6 * i]; }
  const double* end(uint64_t i) const { return &end_[3 * i]; }
  const Knot* bounces_begin(uint64_t i) const { return bounces_.data() + first_bounce_[i]; }
  const Knot* bounces_end(uint64_t i) const { return bounces_.data() + first_bounce_[i + 1]; }

  // Position of body i at time tau since the frame start: linear between consecutive knots.
  void position(uint64_t i, double tau, double out[3]) const {
    double t0 = 0, t1 = dt;
    const double* p0 = start(i);
    const double* p1 = end(i);
    for (const Knot* k = bounces_begin(i); k != bounces_end(i); ++k) {
      if (k->tau <= tau) {
        t0 = k->tau;
        p0 = k->p;
      } else {
        t1 = k->tau;
        p1 = k->p;
        break;
      }
    }
    double f = t1 > t0 ? (tau - t0) / (t1 - t0) : 0.0;
    for (int a = 0; a < 3; ++a) out[a] = p0[a] + f * (p1[a] - p0[a]);
  }

  // The box around body i's whole path in this frame, grown by its radius. A polyline lies in
  // the box of its vertices, so this bounds the bounced path exactly.
  void swept_box(uint64_t i, double lo[3], double hi[3]) const {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(start(i)[a], end(i)[a]);
      hi[a] = std::max(start(i)[a], end(i)[a]);
    }
    for (const Knot* k = bounces_begin(i); k != bounces_end(i); ++k)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], k->p[a]);
        hi[a] = std::max(hi[a], k->p[a]);
      }
    for (int a = 0; a < 3; ++a) {
      lo[a] -= radius;
      hi[a] += radius;
    }
  }

  // Runs a library's linear cast over each piece of the frame in which both bodies move in a
  // straight line (the frame split at either body's bounces). cast(a0, a1, b0, b1, fraction)
  // returns whether the spheres touch while moving from a0 to a1 and b0 to b1, and the fraction
  // of the piece at first touch. A new contact is a touch after a piece's start: touching at a
  // piece's start means the pair still overlaps from before, but it may separate and, after a
  // bounce, meet again in a later piece.
  template <class Cast>
  bool new_contact(uint64_t i, uint64_t j, Cast&& cast) const {
    double cuts[64];
    int count = 0;
    cuts[count++] = 0;
    for (const Knot* k = bounces_begin(i); k != bounces_end(i) && count < 62; ++k) cuts[count++] = k->tau;
    for (const Knot* k = bounces_begin(j); k != bounces_end(j) && count < 62; ++k) cuts[count++] = k->tau;
    cuts[count++] = dt;
    std::sort(cuts, cuts + count);
    for (int c = 0; c + 1 < count; ++c) {
      double ta = cuts[c], tb = cuts[c + 1];
      if (!(tb > ta)) continue;
      double a0[3], a1[3], b0[3], b1[3];
      position(i, ta, a0);
      position(i, tb, a1);
      position(j, ta, b0);
      position(j, tb, b1);
      double fraction;
      if (cast(a0, a1, b0, b1, fraction) && fraction > 0) return true;
    }
    return false;
  }

 private:
  void read(void* to, size_t bytes) {
    if (std::fread(to, 1, bytes, file_) != bytes) throw std::runtime_error("trajectory file is truncated");
  }
  FILE* file_;
  uint64_t frame_ = 0;
  std::vector<double> start_, end_;
  std::vector<uint64_t> first_bounce_;
  std::vector<Knot> bounces_;
};

// What a pipeline found and how long each frame's detection took.
class Report {
 public:
  void begin_frame() { started_ = std::chrono::steady_clock::now(); }
  void end_frame() {
    frame_ms_.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started_).count());
  }
  void contact(uint32_t frame, uint32_t i, uint32_t j) {
    if (i > j) std::swap(i, j);
    contacts_.insert(contacts_.end(), {frame, i, j});
  }
  // Writes the contacts as (frame, i, j) u32 triples and prints the one-line JSON summary the
  // driver reads: per-frame milliseconds and the process's peak resident memory.
  void finish(const char* contacts_path) {
    std::ofstream out(contacts_path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(contacts_.data()), contacts_.size() * 4);
    if (!out) throw std::runtime_error(std::string("cannot write ") + contacts_path);
    std::printf("{\"frame_ms\":[");
    for (size_t k = 0; k < frame_ms_.size(); ++k) std::printf("%s%.6f", k ? "," : "", frame_ms_[k]);
    std::printf("],\"peak_kib\":%ld}\n", peak_kib());
  }

 private:
  static long peak_kib() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
      if (line.rfind("VmHWM:", 0) == 0) return std::atol(line.c_str() + 6);
    return -1;
  }
  std::chrono::steady_clock::time_point started_;
  std::vector<double> frame_ms_;
  std::vector<uint32_t> contacts_;
};

// Frame-instant pipelines see overlaps, not contacts: a contact is a pair overlapping at this
// frame's end that did not overlap at the previous frame's end (the same rule as vadop's
// discrete method). Its cost is part of the frame, as it would be for a user.
class NewOverlaps {
 public:
  void add(uint32_t i, uint32_t j) {
    if (i > j) std::swap(i, j);
    current_.push_back(uint64_t(i) << 32 | j);
  }
  void end_frame(Report& report, uint32_t frame) {
    std::sort(current_.begin(), current_.end());
    current_.erase(std::unique(current_.begin(), current_.end()), current_.end());
    for (uint64_t key : current_)
      if (!std::binary_search(previous_.begin(), previous_.end(), key)) report.contact(frame, uint32_t(key >> 32), uint32_t(key));
    previous_.swap(current_);
    current_.clear();
  }

 private:
  std::vector<uint64_t> previous_, current_;
};

// The first eight bytes of a file: its format's magic.
inline std::string magic_of(const char* path) {
  char magic[8] = {};
  FILE* file = std::fopen(path, "rb");
  if (!file) throw std::runtime_error(std::string("cannot open ") + path);
  size_t read = std::fread(magic, 1, 8, file);
  std::fclose(file);
  return std::string(magic, read);
}

// Runs the pipeline named on the command line over every frame of the trajectory file and
// reports: the shared main of the peer programs. `spheres` runs it on a sphere scene's file,
// `shapes` on a mixed-shape scene's, each returning false for a pipeline it does not know.
// Usage: PROGRAM PIPELINE TRAJECTORY CONTACTS_OUT.
template <class Spheres, class Shapes>
int peer_main(int argc, char** argv, Spheres&& spheres, Shapes&& shapes) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s PIPELINE TRAJECTORY CONTACTS_OUT\n", argv[0]);
    return 2;
  }
  try {
    Report report;
    bool known;
    if (magic_of(argv[2]) == "VADOPSH1") {
      ShapeTrajectory trajectory(argv[2]);
      known = shapes(std::string(argv[1]), trajectory, report);
    } else {
      Trajectory trajectory(argv[2]);
      known = spheres(std::string(argv[1]), trajectory, report);
    }
    if (!known) {
      std::fprintf(stderr, "error: unknown pipeline %s\n", argv[1]);
      return 2;
    }
    report.finish(argv[3]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
