#include "core/io/mesh_io.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/io/file_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

using nlohmann::json;

// Line and column of a byte offset, for parse errors a user can find.
std::string place(std::string_view text, size_t offset) {
    offset = std::min(offset, text.size());
    size_t line = 1, column = 1;
    for (size_t i = 0; i < offset; ++i) {
        if (text[i] == '\n') {
            ++line;
            column = 1;
        } else {
            ++column;
        }
    }
    return str("line ", line, ", column ", column);
}

double number(const json& j, const std::string& name, const std::string& where) {
    if (!j.is_number()) throw Error(str(name, ": ", where, ": expected a number"));
    double v = j.get<double>();
    if (!std::isfinite(v)) throw Error(str(name, ": ", where, ": not a finite number"));
    return v;
}

int32_t index(const json& j, const std::string& name, const std::string& where) {
    if (!j.is_number_integer()) throw Error(str(name, ": ", where, ": expected a vertex index"));
    const int64_t v = j.get<int64_t>();
    if (v < 0 || v > INT32_MAX) throw Error(str(name, ": ", where, ": index ", v, " out of range"));
    return static_cast<int32_t>(v);
}

const json& array_field(const json& doc, const char* key, const std::string& name, bool required) {
    static const json empty = json::array();
    auto it = doc.find(key);
    if (it == doc.end()) {
        if (required) throw Error(str(name, ": missing \"", key, "\""));
        return empty;
    }
    if (!it->is_array()) throw Error(str(name, ": \"", key, "\" must be an array"));
    return *it;
}

// nlohmann::json copies and prints documents recursively; deeper nesting than any mesh or point
// file needs is refused before parsing, so a hostile file cannot overflow the stack.
constexpr int kMaxDepth = 64;

void check_depth(std::string_view text, const std::string& name) {
    int depth = 0;
    bool in_string = false;
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
            if (c == '\\')
                ++i;
            else if (c == '"')
                in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            if (++depth > kMaxDepth) {
                throw Error(
                    str(name, ": ", place(text, i), ": nested deeper than ", kMaxDepth, " levels"));
            }
        } else if (c == ']' || c == '}') {
            --depth;
        }
    }
}

json parse_json(std::string_view text, const std::string& name) {
    text = without_bom(text);
    check_depth(text, name);
    try {
        return json::parse(text);
    } catch (const json::parse_error& e) {
        throw Error(str(name, ": ", place(text, e.byte == 0 ? 0 : e.byte - 1), ": not valid JSON"));
    } catch (const json::exception& e) {  // e.g. a number beyond the range of double
        throw Error(str(name, ": not valid JSON (", e.what(), ")"));
    }
}

}  // namespace

Mesh parse_mesh(std::string_view text, const std::string& name, const MeshLimits& limits) {
    const json doc = parse_json(text, name);
    if (!doc.is_object()) throw Error(name + ": expected a JSON object with \"domain\", ...");
    Mesh mesh;
    const json& domain = array_field(doc, "domain", name, true);
    if (domain.size() != 2) throw Error(name + ": \"domain\" must be [width, height]");
    mesh.width = number(domain[0], name, "domain[0]");
    mesh.height = number(domain[1], name, "domain[1]");
    const json& vertices = array_field(doc, "vertices", name, true);
    if (static_cast<int64_t>(vertices.size()) > limits.max_vertices) {
        throw Error(str(name, ": ", vertices.size(), " vertices exceed the limit of ",
                        limits.max_vertices));
    }
    mesh.vertices.reserve(vertices.size());
    for (size_t i = 0; i < vertices.size(); ++i) {
        const std::string where = str("vertices[", i, "]");
        if (!vertices[i].is_array() || vertices[i].size() != 2) {
            throw Error(str(name, ": ", where, ": expected [x, y]"));
        }
        mesh.vertices.push_back({number(vertices[i][0], name, where + "[0]"),
                                 number(vertices[i][1], name, where + "[1]")});
    }
    const json& faces = array_field(doc, "faces", name, true);
    int64_t corners_total = 0;
    std::vector<int32_t> corners;
    for (size_t f = 0; f < faces.size(); ++f) {
        const std::string where = str("faces[", f, "]");
        if (!faces[f].is_array()) throw Error(str(name, ": ", where, ": expected [i, j, k, ...]"));
        corners_total += static_cast<int64_t>(faces[f].size());
        if (corners_total > limits.max_face_corners) {
            throw Error(str(name, ": more than ", limits.max_face_corners, " face corners"));
        }
        corners.clear();
        for (size_t c = 0; c < faces[f].size(); ++c) {
            corners.push_back(index(faces[f][c], name, str(where, "[", c, "]")));
        }
        mesh.add_face(corners);
    }
    const json& features = array_field(doc, "features", name, false);
    for (size_t i = 0; i < features.size(); ++i) {
        const std::string where = str("features[", i, "]");
        if (!features[i].is_array() || features[i].size() != 2) {
            throw Error(str(name, ": ", where, ": expected [i, j]"));
        }
        mesh.features.push_back({index(features[i][0], name, where + "[0]"),
                                 index(features[i][1], name, where + "[1]")});
    }
    json extra = doc;
    for (const char* key : {"domain", "vertices", "faces", "features"}) extra.erase(key);
    if (!extra.empty()) mesh.extra_json = extra.dump();
    return mesh;
}

Mesh read_mesh(const std::string& path, const MeshLimits& limits) {
    return parse_mesh(read_file(path), path, limits);
}

std::string mesh_to_json(const Mesh& mesh) {
    // One vertex or face per line keeps files diffable and readable.
    std::string out = str("{\n  \"domain\": [", json(mesh.width).dump(), ", ",
                          json(mesh.height).dump(), "],\n  \"vertices\": [");
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        out += str(i ? ",\n    [" : "\n    [", json(mesh.vertices[i].x).dump(), ", ",
                   json(mesh.vertices[i].y).dump(), "]");
    }
    out += "\n  ],\n  \"faces\": [";
    for (int f = 0; f < mesh.num_faces(); ++f) {
        out += f ? ",\n    " : "\n    ";
        out += json(std::vector<int32_t>(mesh.face(f).begin(), mesh.face(f).end())).dump();
    }
    out += "\n  ]";
    if (!mesh.features.empty()) out += str(",\n  \"features\": ", json(mesh.features).dump());
    if (!mesh.extra_json.empty()) {
        const json extra = json::parse(mesh.extra_json);
        for (auto& [key, value] : extra.items()) {
            out += str(",\n  ", json(key).dump(), ": ", value.dump());
        }
    }
    return out + "\n}\n";
}

void write_mesh(const Mesh& mesh, const std::string& path) {
    write_file_atomic(path, mesh_to_json(mesh));
}

std::vector<Vec2> parse_points(std::string_view text, const std::string& name) {
    text = without_bom(text);
    std::vector<Vec2> points;
    size_t first = text.find_first_not_of(" \t\r\n");
    if (first != std::string_view::npos && text[first] == '[') {
        const json doc = parse_json(text, name);
        if (!doc.is_array()) throw Error(name + ": expected a JSON array of [x, y]");
        for (size_t i = 0; i < doc.size(); ++i) {
            const std::string where = str("point ", i);
            if (!doc[i].is_array() || doc[i].size() != 2) {
                throw Error(str(name, ": ", where, ": expected [x, y]"));
            }
            points.push_back({number(doc[i][0], name, where), number(doc[i][1], name, where)});
        }
        return points;
    }
    size_t line_no = 0, pos = 0;
    while (pos <= text.size()) {
        size_t end = text.find('\n', pos);
        if (end == std::string_view::npos) end = text.size();
        std::string line(text.substr(pos, end - pos));
        pos = end + 1;
        ++line_no;
        if (auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
        for (char& c : line) c = (c == ',' || c == '\t' || c == '\r') ? ' ' : c;
        if (line.find_first_not_of(' ') == std::string::npos) continue;
        std::istringstream in(line);
        double x, y;
        std::string rest;
        if (!(in >> x >> y) || (in >> rest)) {
            throw Error(str(name, ": line ", line_no, ": expected two numbers \"x y\""));
        }
        if (!std::isfinite(x) || !std::isfinite(y)) {
            throw Error(str(name, ": line ", line_no, ": not a finite number"));
        }
        points.push_back({x, y});
        if (points.size() > 50'000'000) throw Error(name + ": too many points");
    }
    return points;
}

std::vector<Vec2> read_points(const std::string& path) {
    return parse_points(read_file(path), path);
}

}  // namespace tesswave
