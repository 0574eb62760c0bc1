// Crafted .twv files for the robustness and limits tests: a header and chunks with valid CRCs,
// and the groups and frames they are made of.
#pragma once

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "temp_dir.h"
#include "video/twv_format.h"

namespace tesswave::video {

using Bytes = std::vector<uint8_t>;

inline Bytes read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), {});
}

inline void write_bytes(const std::string& path, const Bytes& b) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

// A file of a header (32x24 frames unless given) and the given chunks (valid CRCs), without an
// index.
inline std::string crafted(const std::vector<Bytes>& chunks,
                           const TwvHeader& header = {.width = 32, .height = 24}) {
    Bytes file = write_twv_header(header);
    for (const Bytes& c : chunks) file.insert(file.end(), c.begin(), c.end());
    static const testing::TempDir dir("twv_crafted");
    const std::string path = dir / "crafted.twv";
    write_bytes(path, file);
    return path;
}

inline Bytes group_chunk(TwvGroup g) { return twv_chunk('G', write_twv_group(g)); }

// A fixed-grid 5/3 group of `levels` for `header`'s frames, and its intra frame with no planes.
inline TwvGroup grid_group(const TwvHeader& header, int levels) {
    TwvGroup g{.transform = TwiTransform::grid53, .levels = levels, .channel_factors = {1, 1, 1}};
    g.band_norms.assign(twv_band_count(g, header), 1.0f);
    return g;
}

inline TwvFrame empty_intra(const TwvGroup& g) {
    TwvFrame intra{.number = 0, .kind = TwvFrameKind::intra};
    intra.planes.assign(3, std::vector<uint8_t>(g.band_norms.size(), 0));
    return intra;
}

}  // namespace tesswave::video
