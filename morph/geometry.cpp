#include "geometry.h"

#include <algorithm>
#include <cmath>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::morph {
namespace {

// Neighbours of every vertex along face edges (each listed once).
std::vector<std::vector<int32_t>> vertex_neighbours(const Mesh& mesh) {
    std::vector<std::vector<int32_t>> nb(mesh.num_vertices());
    for (int f = 0; f < mesh.num_faces(); ++f) {
        const auto face = mesh.face(f);
        const size_t k = face.size();
        for (size_t i = 0; i < k; ++i) {
            const int32_t a = face[i], b = face[(i + 1) % k];
            if (std::find(nb[a].begin(), nb[a].end(), b) == nb[a].end()) nb[a].push_back(b);
            if (std::find(nb[b].begin(), nb[b].end(), a) == nb[b].end()) nb[b].push_back(a);
        }
    }
    return nb;
}

}  // namespace

std::vector<int> folded_faces(const Mesh& mesh, std::span<const Vec2> v, double min_sine) {
    std::vector<int> out;
    for (int f = 0; f < mesh.num_faces(); ++f) {
        const auto face = mesh.face(f);
        const size_t k = face.size();
        for (size_t i = 0; i < k; ++i) {
            const Vec2 p = v[face[(i + k - 1) % k]], q = v[face[i]], r = v[face[(i + 1) % k]];
            const Vec2 e0 = q - p, e1 = r - q;
            if (!(cross(e0, e1) > min_sine * norm(e0) * norm(e1))) {
                out.push_back(f);
                break;
            }
        }
    }
    return out;
}

std::vector<Vec2> interpolate_geometry(const Mesh& mesh, std::span<const Vec2> a,
                                       std::span<const Vec2> b, double s, GeometryReport* report) {
    if (a.size() != b.size() || static_cast<int>(a.size()) != mesh.num_vertices()) {
        throw Error("geometry: the two vertex sets do not match the mesh");
    }
    std::vector<Vec2> v(a.size());
    for (size_t i = 0; i < a.size(); ++i) v[i] = lerp(a[i], b[i], s);
    std::vector<int> folded = folded_faces(mesh, v);
    GeometryReport r{static_cast<int>(folded.size()), 0};
    if (!folded.empty()) {
        const auto nb = vertex_neighbours(mesh);
        const double W = mesh.width, H = mesh.height;
        auto on = [](double x, double edge) { return std::abs(x - edge) < 1e-9; };
        std::vector<char> move(v.size());
        for (; !folded.empty() && r.iterations < 500; ++r.iterations) {
            std::fill(move.begin(), move.end(), 0);
            for (int f : folded) {
                for (int32_t i : mesh.face(f)) move[i] = 1;
            }
            const std::vector<Vec2> before = v;
            for (size_t i = 0; i < v.size(); ++i) {
                if (!move[i] || nb[i].empty()) continue;
                Vec2 mean{};
                for (int32_t j : nb[i]) mean = mean + before[j];
                mean = (1.0 / nb[i].size()) * mean;
                const bool x_fixed = on(before[i].x, 0) || on(before[i].x, W);
                const bool y_fixed = on(before[i].y, 0) || on(before[i].y, H);
                if (!x_fixed) v[i].x = 0.5 * (before[i].x + mean.x);
                if (!y_fixed) v[i].y = 0.5 * (before[i].y + mean.y);
            }
            folded = folded_faces(mesh, v);
        }
        if (!folded.empty()) {
            throw Error(str("the in-between mesh at s = ", s, " folds (face ", folded.front(),
                            ") and relaxing it did not repair it"));
        }
    }
    if (report) *report = r;
    return v;
}

}  // namespace tesswave::morph
