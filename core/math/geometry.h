// Small 2D vector helpers in image coordinates (x right, y down), shared by every module.
#pragma once

#include <cmath>

namespace tesswave {

struct Vec2 {
    double x = 0.0;
    double y = 0.0;
};

constexpr Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
constexpr Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
constexpr Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
constexpr bool operator==(Vec2 a, Vec2 b) { return a.x == b.x && a.y == b.y; }

// z-component of the cross product; > 0 when b turns counterclockwise from a in (x, y).
constexpr double cross(Vec2 a, Vec2 b) { return a.x * b.y - a.y * b.x; }
constexpr double dot(Vec2 a, Vec2 b) { return a.x * b.x + a.y * b.y; }
inline double norm(Vec2 a) { return std::hypot(a.x, a.y); }
constexpr Vec2 lerp(Vec2 a, Vec2 b, double t) {
    return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
}

}  // namespace tesswave
