// The peer programs' side of vadop's mixed-shape trajectory file: reads the shape table and the
// bodies' states one frame at a time. Owns the file format (written by
// crates/vadop-bench/src/peers/shapes.rs, which documents it; keep the two in step).
//
// Within a frame a body's centre of mass moves in a straight line and the body turns about it at
// a constant angular velocity (every spin is about a principal axis, and no body reaches a wall),
// from the frame's start state to its end state, which is the next frame's start.
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

enum class Kind : uint64_t { Sphere = 0, Cuboid = 1, Capsule = 2, Cylinder = 3, Cone = 4, ConvexHull = 5 };

// One shape in its own frame: capsules, cylinders and cones lie along y, a cone's apex at
// +half height.
struct ShapeSpec {
  Kind kind;
  // Sphere: radius; cuboid: half extents; capsule, cylinder, cone: half height and radius.
  double size[3];
  // Its centre of mass, the point it turns about, in its own frame.
  double centre[3];
  // The radius about the centre of mass that holds the whole shape.
  double bounding_radius;
  // A convex hull's vertices (x, y, z each) and triangles; empty for the other kinds.
  std::vector<double> vertices;
  std::vector<uint32_t> triangles;
};

// A body's state at an instant: its shape frame's position and orientation (x, y, z, w), its
// centre of mass's velocity and its angular velocity in world axes, per unit of time.
struct State {
  double position[3];
  double orientation[4];
  double velocity[3];
  double angular_velocity[3];
};

// v turned by the unit quaternion q (x, y, z, w).
inline void rotate(const double q[4], const double v[3], double out[3]) {
  // v + 2 w (u x v) + 2 u x (u x v), u the vector part.
  double t[3] = {2 * (q[1] * v[2] - q[2] * v[1]), 2 * (q[2] * v[0] - q[0] * v[2]), 2 * (q[0] * v[1] - q[1] * v[0])};
  out[0] = v[0] + q[3] * t[0] + (q[1] * t[2] - q[2] * t[1]);
  out[1] = v[1] + q[3] * t[1] + (q[2] * t[0] - q[0] * t[2]);
  out[2] = v[2] + q[3] * t[2] + (q[0] * t[1] - q[1] * t[0]);
}

class ShapeTrajectory {
 public:
  uint64_t n = 0, frames = 0;
  double dt = 0, box_min[3], box_max[3];
  std::vector<ShapeSpec> shapes;
  // Each body's index into shapes.
  std::vector<uint32_t> shape_of;

  explicit ShapeTrajectory(const char* path) : file_(std::fopen(path, "rb")) {
    if (!file_) throw std::runtime_error(std::string("cannot open ") + path);
    char magic[8];
    read(magic, 8);
    if (std::string(magic, 8) != "VADOPSH1") throw std::runtime_error("not a vadop shapes trajectory file");
    read(&n, 8);
    read(&frames, 8);
    read(&dt, 8);
    read(box_min, 24);
    read(box_max, 24);
    uint64_t count;
    read(&count, 8);
    shapes.resize(count);
    for (ShapeSpec& s : shapes) {
      read(&s.kind, 8);
      read(s.size, 24);
      read(s.centre, 24);
      read(&s.bounding_radius, 8);
      uint64_t vertices, triangles;
      read(&vertices, 8);
      read(&triangles, 8);
      s.vertices.resize(3 * vertices);
      s.triangles.resize(3 * triangles);
      read(s.vertices.data(), s.vertices.size() * 8);
      read(s.triangles.data(), s.triangles.size() * 4);
    }
    shape_of.resize(n);
    read(shape_of.data(), n * 4);
    for (uint32_t s : shape_of)
      if (s >= count) throw std::runtime_error("a body's shape is not in the shape table");
    start_.resize(n);
    end_.resize(n);
    read(end_.data(), n * sizeof(State));
  }
  ~ShapeTrajectory() { std::fclose(file_); }

  // Loads the next frame (its start and end states); false after the last.
  bool next_frame() {
    if (frame_ == frames) return false;
    start_.swap(end_);
    read(end_.data(), n * sizeof(State));
    ++frame_;
    return true;
  }
  // Index of the frame loaded by the last next_frame().
  uint32_t frame() const { return uint32_t(frame_ - 1); }

  const ShapeSpec& shape(uint64_t i) const { return shapes[shape_of[i]]; }
  const State& start(uint64_t i) const { return start_[i]; }
  const State& end(uint64_t i) const { return end_[i]; }

  // Where body i's centre of mass is in `state`.
  void centre_of_mass(uint64_t i, const State& state, double out[3]) const {
    rotate(state.orientation, shape(i).centre, out);
    for (int a = 0; a < 3; ++a) out[a] += state.position[a];
  }

  // The box around everything body i covers in this frame: its centre of mass moves in a
  // straight line and the shape stays within its bounding radius of it, however it turns.
  void swept_box(uint64_t i, double lo[3], double hi[3]) const {
    double a[3], b[3];
    centre_of_mass(i, start(i), a);
    centre_of_mass(i, end(i), b);
    double r = shape(i).bounding_radius;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(a[k], b[k]) - r;
      hi[k] = std::max(a[k], b[k]) + r;
    }
  }

 private:
  void read(void* to, size_t bytes) {
    if (std::fread(to, 1, bytes, file_) != bytes) throw std::runtime_error("trajectory file is truncated");
  }
  FILE* file_;
  uint64_t frame_ = 0;
  std::vector<State> start_, end_;
};
