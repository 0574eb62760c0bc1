// tesswave info: what a .twi image or a .twv clip holds.
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "core/codec/twi_format.h"
#include "core/io/file_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "video/dec_video.h"

namespace tesswave::cli {
namespace {

nlohmann::json twi_info(const std::string& path, int64_t max_pixels) {
    const std::string bytes = read_file(path);
    const std::span<const uint8_t> file(reinterpret_cast<const uint8_t*>(bytes.data()),
                                        bytes.size());
    const TwiHeader h = read_twi_header(file, path, limits_for<TwiLimits>(max_pixels));
    nlohmann::json j = {{"file", path},
                        {"format", "twi"},
                        {"bytes", bytes.size()},
                        {"header_bytes", h.header_bytes},
                        {"width", h.width},
                        {"height", h.height},
                        {"channels", h.channels},
                        {"bit_depth", h.bit_depth},
                        {"transform", transform_name(h.transform)},
                        {"lossless", h.lossless},
                        {"levels", h.levels},
                        {"bands", h.band_norms.size()},
                        {"bpp", bytes.size() * 8.0 / (double(h.width) * h.height)}};
    if (h.transform == TwiTransform::mesh) {
        j["mesh"] = h.grid_cols > 0
                        ? str("grid ", h.grid_cols, "x", h.grid_rows)
                        : str(h.mesh.num_vertices(), " vertices, ", h.mesh.num_faces(), " faces");
        j["placement"] = h.placement == MeshPlacement::centres ? "pixel centres" : "area";
        j["mesh_wavelet"] =
            h.mesh_wavelet == MeshWavelet::lattice97 ? "9/7 on the mesh lattice" : "lifted";
    }
    return j;
}

nlohmann::json twv_info(const std::string& path, int64_t max_pixels) {
    video::VideoDecoder decoder(path, limits_for<video::TwvLimits>(max_pixels));
    const video::TwvHeader& h = decoder.header();
    int64_t frames = 0, intra_bytes = 0, delta_bytes = 0, band_bytes = 0, motion_bytes = 0;
    int64_t groups = 0, repeated = 0;
    std::map<std::string, int> domains;
    while (decoder.skim()) {  // headers and chunks only: describing a file decodes nothing
        const video::TwvFrameInfo& f = decoder.info();
        frames += 1 + f.repeats;
        repeated += f.repeats;
        motion_bytes += f.motion_bytes;
        (f.kind == video::TwvFrameKind::intra   ? intra_bytes
         : f.kind == video::TwvFrameKind::delta ? delta_bytes
                                                : band_bytes) += f.bytes;
        const video::TwvGroup& g = decoder.group();
        if (f.number != g.first_frame) continue;
        ++groups;
        std::string d = str(transform_name(g.transform), ", ", g.levels, " levels");
        if (g.transform == TwiTransform::mesh) {
            d += str(", grid ", g.grid_cols, "x", g.grid_rows, ", ",
                     g.motion == video::TwvMotion::tracked ? "tracked" : "static",
                     g.mesh_wavelet == MeshWavelet::lattice97 ? ", 9/7 on the mesh lattice"
                                                              : ", bilinear mesh wavelet");
            if (g.has_canvas()) {
                d += str(", canvas ", h.width + g.extend_x, "x", h.height + g.extend_y);
            }
        }
        d += g.lifted > 0 ? ", lifted along time" : ", low delay";
        ++domains[d];
    }
    if (frames == 0) {
        // The damage note names the file itself; the message names it once.
        std::string why = decoder.damage();
        if (why.starts_with(path + ": ")) why.erase(0, path.size() + 2);
        throw Error(str(path, ": no decodable frame", why.empty() ? "" : " (" + why + ")"));
    }
    const double seconds = frames / h.fps();
    nlohmann::json j = {
        {"file", path},
        {"format", "twv"},
        {"bytes", decoder.file_bytes()},
        {"width", h.width},
        {"height", h.height},
        {"fps", h.fps()},
        {"frames", frames},
        {"groups", groups},
        {"repeated_frames", repeated},
        {"indexed", decoder.frame_count().has_value()},
        {"intra_bytes", intra_bytes},
        {"delta_bytes", delta_bytes},
        {"band_bytes", band_bytes},
        {"motion_bytes", motion_bytes},
        {"kbps", seconds > 0 ? decoder.file_bytes() * 8.0 / 1000 / seconds : 0},
        {"bpp",
         frames > 0 ? decoder.file_bytes() * 8.0 / (double(frames) * h.width * h.height) : 0},
        {"damage", decoder.damage()}};
    nlohmann::json d = nlohmann::json::array();
    for (const auto& [name, count] : domains) d.push_back({{"domain", name}, {"groups", count}});
    j["domains"] = d;
    return j;
}

void run_info(const std::string& path, bool json, int64_t max_pixels) {
    char magic[4] = {};
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(str(path, ": cannot open"));
    in.read(magic, 4);
    nlohmann::json j;
    if (in && std::string(magic, 3) == "TWV") {
        j = twv_info(path, max_pixels);
    } else if (in && std::string(magic, 3) == "TWI") {
        j = twi_info(path, max_pixels);
    } else {
        throw Error(str(path, ": neither a .twi nor a .twv file"));
    }
    if (json) {
        std::printf("%s\n", j.dump(2).c_str());
        return;
    }
    for (const auto& [key, value] : j.items()) {
        if (key == "domains") {
            for (const auto& d : value) {
                const int groups = d["groups"].get<int>();
                std::printf("%-16s %s (%d group%s)\n", "domain",
                            d["domain"].get<std::string>().c_str(), groups, groups == 1 ? "" : "s");
            }
        } else if (key != "damage" || !value.get<std::string>().empty()) {
            // Six significant digits for a reader (--json keeps every digit).
            const std::string text = value.is_string()         ? value.get<std::string>()
                                     : value.is_number_float() ? str(value.get<double>())
                                                               : value.dump();
            std::printf("%-16s %s\n", key.c_str(), text.c_str());
        }
    }
}

}  // namespace

void add_info_command(CLI::App& app) {
    auto path = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    auto max_pixels = std::make_shared<int64_t>(0);
    auto* cmd = app.add_subcommand("info", "Describe a .twi image or a .twv clip (headers only)");
    cmd->add_option("file", *path, "A .twi or .twv file")->required();
    add_max_pixels_option(cmd, *max_pixels);
    cmd->add_flag("--json", *json, "Print as JSON");
    cmd->callback([path, json, max_pixels] { run_info(*path, *json, *max_pixels); });
}

}  // namespace tesswave::cli
