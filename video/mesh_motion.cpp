#include "mesh_motion.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

#include "core/codec/range_coder.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave::video {
namespace {

constexpr int kMaxExponent = 30;

// Adaptive models of one axis: zero flags by the previous residual's class, sign, and the
// Exp-Golomb prefix and suffix bits by position.
struct AxisModels {
    std::array<BitModel, 3> zero;
    BitModel sign;
    std::array<BitModel, kMaxExponent + 1> prefix;
    std::array<BitModel, kMaxExponent + 1> suffix;

    void settle() {
        for (BitModel& b : zero) b = BitModel::settled();
        sign = BitModel::settled();
        for (BitModel& b : prefix) b = BitModel::settled();
        for (BitModel& b : suffix) b = BitModel::settled();
    }
};

int context_of(int64_t previous) { return previous == 0 ? 0 : (std::abs(previous) == 1 ? 1 : 2); }

int64_t to_units(double v) { return std::llround(v * kMotionUnit); }

// Per vertex, up to two mesh neighbours with smaller ids (coded before it in the same frame).
std::vector<std::array<int32_t, 2>> earlier_neighbours(const Mesh& mesh) {
    std::vector<std::array<int32_t, 2>> out(mesh.vertices.size(), {-1, -1});
    for (int f = 0; f < mesh.num_faces(); ++f) {
        const auto face = mesh.face(f);
        for (size_t c = 0; c < face.size(); ++c) {
            const int32_t a = face[c], b = face[(c + 1) % face.size()];
            const int32_t hi = std::max(a, b), lo = std::min(a, b);
            auto& slot = out[hi];
            if (slot[0] == lo || slot[1] == lo) continue;
            if (slot[0] < 0) {
                slot[0] = lo;
            } else if (slot[1] < 0 || lo > slot[1]) {
                slot[1] = lo;  // keep the nearest in numbering
            }
        }
    }
    return out;
}

int64_t median3(int64_t a, int64_t b, int64_t c) {
    return std::max(std::min(a, b), std::min(std::max(a, b), c));
}

// Units of 1/kMotionUnit pixel; positions are multiples of it.
int64_t unit(const Vec2& p, int axis) { return to_units(axis == 0 ? p.x : p.y); }

// The velocity predicted for vertex i: the median of its own last velocity and the velocities
// of two already coded neighbours in this frame (a pan predicts exactly after the first vertex).
struct Predictor {
    std::span<const Vec2> previous, before;
    std::vector<std::array<int32_t, 2>> earlier;
    std::vector<std::array<int64_t, 2>> velocity;  // of the current frame, as decoded so far

    int64_t predict(size_t i, int axis) const {
        const int64_t last = before.empty() ? 0 : unit(previous[i], axis) - unit(before[i], axis);
        const auto [a, b] = earlier[i];
        if (a < 0) return last;
        if (b < 0) return (last + velocity[a][axis]) / 2;
        return median3(last, velocity[a][axis], velocity[b][axis]);
    }
};

void encode_residual(RangeEncoder& e, AxisModels& m, int64_t d, int context) {
    e.encode(m.zero[context], d == 0 ? 0 : 1);
    if (d == 0) return;
    e.encode(m.sign, d < 0 ? 1 : 0);
    // Magnitude - 1 as Exp-Golomb: k leading ones, a zero, then the k low bits of (value + 1).
    const uint64_t v = static_cast<uint64_t>(d < 0 ? -d : d);  // >= 1
    const int k = std::bit_width(v) - 1;
    for (int i = 0; i < k; ++i) e.encode(m.prefix[i], 1);
    if (k < kMaxExponent) e.encode(m.prefix[k], 0);
    for (int i = k - 1; i >= 0; --i) e.encode(m.suffix[i], static_cast<int>((v >> i) & 1));
}

int64_t decode_residual(RangeDecoder& d, AxisModels& m, int context) {
    if (d.decode(m.zero[context]) == 0) return 0;
    const bool negative = d.decode(m.sign) == 1;
    int k = 0;
    while (k < kMaxExponent && d.decode(m.prefix[k]) == 1) ++k;
    uint64_t v = 1;
    for (int i = k - 1; i >= 0; --i) v = (v << 1) | static_cast<uint64_t>(d.decode(m.suffix[i]));
    const int64_t s = static_cast<int64_t>(v);
    return negative ? -s : s;
}

}  // namespace

std::vector<Vec2> round_to_motion_unit(std::span<const Vec2> positions) {
    std::vector<Vec2> out(positions.size());
    for (size_t i = 0; i < positions.size(); ++i) {
        out[i] = {to_units(positions[i].x) / kMotionUnit, to_units(positions[i].y) / kMotionUnit};
    }
    return out;
}

std::vector<uint8_t> encode_motion(const Mesh& mesh, std::span<const Vec2> current,
                                   std::span<const Vec2> previous, std::span<const Vec2> before) {
    if (current.size() != mesh.vertices.size() || previous.size() != current.size() ||
        (!before.empty() && before.size() != current.size())) {
        throw Error("vertex counts differ between frames");
    }
    Predictor p{previous, before, earlier_neighbours(mesh), {}};
    p.velocity.resize(current.size());
    RangeEncoder e;
    std::array<AxisModels, 2> models{};
    std::array<int64_t, 2> last{0, 0};
    for (size_t i = 0; i < current.size(); ++i) {
        for (int axis = 0; axis < 2; ++axis) {
            const int64_t v = unit(current[i], axis) - unit(previous[i], axis);
            const int64_t d = v - p.predict(i, axis);
            encode_residual(e, models[axis], d, context_of(last[axis]));
            last[axis] = d;
            p.velocity[i][axis] = v;
        }
    }
    return e.finish();
}

std::vector<Vec2> decode_motion(std::span<const uint8_t> bytes, std::span<const Vec2> previous,
                                std::span<const Vec2> before, const Mesh& mesh,
                                const std::string& what, bool fast_start) {
    if (previous.size() != mesh.vertices.size() ||
        (!before.empty() && before.size() != previous.size())) {
        throw Error(str(what, ": vertex counts differ between frames"));
    }
    Predictor p{previous, before, earlier_neighbours(mesh), {}};
    p.velocity.resize(previous.size());
    RangeDecoder d(bytes);
    std::array<AxisModels, 2> models{};
    if (!fast_start) {
        for (AxisModels& m : models) m.settle();
    }
    std::array<int64_t, 2> last{0, 0};
    const int64_t max_x = to_units(mesh.width), max_y = to_units(mesh.height);
    std::vector<Vec2> out(previous.size());
    for (size_t i = 0; i < previous.size(); ++i) {
        std::array<int64_t, 2> c{};
        for (int axis = 0; axis < 2; ++axis) {
            const int64_t r = decode_residual(d, models[axis], context_of(last[axis]));
            last[axis] = r;
            // Residuals stay below 2^31 and velocities are checked below, so nothing overflows.
            p.velocity[i][axis] = p.predict(i, axis) + r;
            c[axis] = unit(previous[i], axis) + p.velocity[i][axis];
        }
        if (d.exhausted()) throw Error(str(what, ": truncated vertex motion"));
        if (c[0] < 0 || c[0] > max_x || c[1] < 0 || c[1] > max_y) {
            throw Error(str(what, ": vertex ", i, " moves outside the frame"));
        }
        out[i] = {c[0] / kMotionUnit, c[1] / kMotionUnit};
    }
    if (!validate(mesh, out, {.max_problems = 1}).ok()) {
        throw Error(str(what, ": the moved mesh is not valid"));
    }
    return out;
}

}  // namespace tesswave::video
