// Deterministic mutations of mesh files, point lists and Mesh structs for the robustness
// campaigns: token and number edits on text, and structural edits (moved, merged and renumbered
// vertices, reversed, dropped and split faces, bad indices) on meshes.
#pragma once

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/math/mesh.h"
#include "robustness.h"
#include "test_meshes.h"

namespace tesswave::testing {

inline uint64_t below(std::mt19937_64& rng, uint64_t n) { return rng() % n; }

// ---- Text mutations ----

inline constexpr std::string_view kTokens[] = {"-1",        "1e308",       "NaN",
                                               "[]",        "{}",          "\"x\"",
                                               ",",         "99999999999", "0",
                                               "-0",        "2147483647",  "4e-324",
                                               "null",      "[",           "]",
                                               "{",         "}",           ":",
                                               "\"faces\"", "0.5",         "18446744073709551616",
                                               " "};

// [begin, end) of every number-like run in the text.
inline std::vector<std::pair<size_t, size_t>> number_spans(std::string_view text) {
    auto digit = [](char c) { return c >= '0' && c <= '9'; };
    std::vector<std::pair<size_t, size_t>> out;
    for (size_t i = 0; i < text.size();) {
        if (!(digit(text[i]) || text[i] == '-')) {
            ++i;
            continue;
        }
        size_t j = i + 1;
        while (j < text.size() && (digit(text[j]) || std::string_view(".eE+-").find(text[j]) !=
                                                         std::string_view::npos)) {
            ++j;
        }
        out.push_back({i, j});
        i = j;
    }
    return out;
}

inline std::string mutate_text(std::string text, std::mt19937_64& rng) {
    const size_t n = text.size();
    const std::string_view token = kTokens[below(rng, std::size(kTokens))];
    if (n == 0) return std::string(token);
    const auto spans = number_spans(text);
    switch (below(rng, 7)) {
        case 0:  // flip one bit
            text[below(rng, n)] ^= static_cast<char>(1 << below(rng, 8));
            break;
        case 1:  // replace a byte
            text[below(rng, n)] = static_cast<char>(rng());
            break;
        case 2: {                             // delete up to 8 bytes
            const size_t at = below(rng, n);  // draws in separate statements: a fixed order
            text.erase(at, 1 + below(rng, 8));
            break;
        }
        case 3:  // insert a JSON-ish token
            text.insert(below(rng, n + 1), token);
            break;
        case 4:  // swap two numbers
            if (spans.size() >= 2) {
                auto x = spans[below(rng, spans.size())], y = spans[below(rng, spans.size())];
                if (x.first > y.first) std::swap(x, y);
                if (x.first == y.first) break;
                text = text.substr(0, x.first) + text.substr(y.first, y.second - y.first) +
                       text.substr(x.second, y.first - x.second) +
                       text.substr(x.first, x.second - x.first) + text.substr(y.second);
            }
            break;
        case 5:  // replace a number by a token
            if (!spans.empty()) {
                auto [b, e] = spans[below(rng, spans.size())];
                text.replace(b, e - b, token);
            }
            break;
        default: {  // duplicate a slice somewhere else
            const size_t from = below(rng, n), length = 1 + below(rng, 40), to = below(rng, n + 1);
            text.insert(to, text.substr(from, length));
        }
    }
    return text;
}

// ---- Mesh mutations (serialized afterwards, or checked directly) ----

inline std::vector<std::vector<int32_t>> faces_of(const Mesh& mesh) {
    std::vector<std::vector<int32_t>> faces;
    for (int f = 0; f < mesh.num_faces(); ++f)
        faces.emplace_back(mesh.face(f).begin(), mesh.face(f).end());
    return faces;
}

inline void set_faces(Mesh& mesh, const std::vector<std::vector<int32_t>>& faces) {
    mesh.face_offsets = {0};
    mesh.face_corners.clear();
    for (const auto& face : faces) mesh.add_face(face);
}

// Vertex ids renumbered by `perm` (new id of old vertex v is perm[v]).
inline void renumber(Mesh& mesh, const std::vector<int32_t>& perm) {
    std::vector<Vec2> moved(mesh.vertices.size());
    for (size_t v = 0; v < perm.size(); ++v) moved[perm[v]] = mesh.vertices[v];
    mesh.vertices = moved;
    const auto map = [&](int32_t v) { return v >= 0 && v < mesh.num_vertices() ? perm[v] : v; };
    for (int32_t& c : mesh.face_corners) c = map(c);
    for (auto& feature : mesh.features) feature = {map(feature[0]), map(feature[1])};
}

inline void mutate_mesh(Mesh& mesh, std::mt19937_64& rng) {
    auto faces = faces_of(mesh);
    const size_t fi = below(rng, faces.size());
    auto& face = faces[fi];
    const int32_t nv = mesh.num_vertices();
    Vec2& v = mesh.vertices[below(rng, nv)];
    const Vec2 w = mesh.vertices[below(rng, nv)];
    const double diag = std::hypot(mesh.width, mesh.height);
    // Earlier mutations may have left out-of-range ids behind; they stand for vertex w here.
    const size_t corner = below(rng, face.size());
    const int32_t a = face[corner], b = face[(corner + 1) % face.size()];
    const Vec2 pa = a < nv ? mesh.vertices[a] : w, pb = b < nv ? mesh.vertices[b] : w;
    switch (below(rng, 15)) {
        case 0:
            faces.push_back(face);
            break;
        case 1: {  // move by up to 10^-k of the diagonal
            const double amount = diag * std::pow(10.0, -static_cast<double>(below(rng, 15)));
            v = v + amount * Vec2{uniform(rng) - 0.5, uniform(rng) - 0.5};
            break;
        }
        case 2:
            std::reverse(face.begin(), face.end());
            break;
        case 3:
            if (faces.size() > 1) faces.erase(faces.begin() + static_cast<std::ptrdiff_t>(fi));
            break;
        case 4: {
            const int32_t bad[] = {nv, nv + 1, std::numeric_limits<int32_t>::max()};
            face[corner] = bad[below(rng, 3)];
            break;
        }
        case 5:
            mesh.features.push_back({a, b});
            break;
        case 6:
            mesh.features.push_back(
                {static_cast<int32_t>(below(rng, nv)), static_cast<int32_t>(below(rng, nv))});
            break;
        case 7:
            if (face.size() > 1) face.erase(face.begin() + static_cast<std::ptrdiff_t>(corner));
            break;
        case 8:
            std::swap(v, mesh.vertices[below(rng, nv)]);
            break;
        case 9:  // snap to a domain side
            (below(rng, 2) ? v.x : v.y) =
                below(rng, 2) ? 0.0 : (below(rng, 2) ? mesh.width : mesh.height);
            break;
        case 10:  // onto an edge (a T-node, or a collapse when v is a or b)
            v = lerp(pa, pb, uniform(rng));
            break;
        case 11:  // next to another vertex
            v = w + diag * std::pow(10.0, -static_cast<double>(below(rng, 16))) * Vec2{1, -1};
            break;
        case 12:  // rotate the corner list: the same face
            std::rotate(face.begin(), face.begin() + static_cast<std::ptrdiff_t>(corner),
                        face.end());
            break;
        case 13: {  // shuffle the vertex numbering: the same mesh
            set_faces(mesh, faces);
            std::vector<int32_t> perm(nv);
            for (int32_t i = 0; i < nv; ++i) perm[i] = i;
            for (int32_t i = nv - 1; i > 0; --i) std::swap(perm[i], perm[below(rng, i + 1)]);
            renumber(mesh, perm);
            return;
        }
        default:  // a new vertex on edge (a, b), listed by this face only
            mesh.vertices.push_back(lerp(pa, pb, 0.5));
            face.insert(face.begin() + static_cast<std::ptrdiff_t>(corner) + 1, nv);
    }
    set_faces(mesh, faces);
}

}  // namespace tesswave::testing
