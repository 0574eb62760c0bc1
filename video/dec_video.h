// The .twv decoder (DESIGN.md 4): reads a clip chunk by chunk. In a low-delay group it keeps the
// previous frame's decoded coefficients and vertex positions and adds each delta frame's residual;
// a lifted group is read whole when it starts (its temporal bands and each frame's motion), then
// inverted along time (temporal.h), and its frames are rendered one by one. Needs neither
// tracking nor fitting. Memory holds one group's domain and one group's coefficients (within
// TwvLimits::max_group_bytes), whatever the clip's length; the frames decoded, and a lifted group's
// coefficients, are weighed against the file's size (TwvLimits) before the work. A cut or damaged
// file decodes up to its last whole, intact frame (in a lifted group, every frame whose chunk
// arrived, the missing bands taken as zero); damage() then says where and why.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/codec/byte_io.h"
#include "core/math/image.h"
#include "twv_domain.h"
#include "twv_format.h"

namespace tesswave::video {

struct TwvFrameInfo {
    int64_t number = 0;
    TwvFrameKind kind = TwvFrameKind::intra;
    int64_t bytes = 0;         // the whole chunk (0 for a repeat)
    int64_t motion_bytes = 0;  // vertex motion within it
    int64_t repeats = 0;       // copies of the frame that follow it (version 5)
    bool repeat = false;       // a copy of the frame before (it has no chunk of its own)
};

class VideoDecoder {
  public:
    // Throws Error("<path>: ...") for a missing or unreadable file or a damaged file header.
    explicit VideoDecoder(const std::string& path, const TwvLimits& limits = {});
    // The same from any byte source (a file, bytes in memory); `name` prefixes messages.
    VideoDecoder(std::unique_ptr<ByteSource> source, const std::string& name,
                 const TwvLimits& limits = {});
    ~VideoDecoder();

    const TwvHeader& header() const { return header_; }
    int64_t file_bytes() const { return file_size_; }
    // From the index; nullopt when the file has none (cut files).
    std::optional<int64_t> frame_count() const;
    std::optional<int64_t> group_count() const;

    // The next frame: true and `out` filled, or false at the end of the clip or at the first
    // damage (then damage() is non-empty). With `render` false the frame is decoded but not
    // rendered (seeking past frames).
    bool read(Image& out, bool render = true);
    // Positions the decoder so that the next read() returns frame `frame`: from the index, it
    // starts at that frame's group (false for a frame past the last); without one it decodes
    // from the start (or on from where it is). False (with damage()) when the clip breaks first.
    bool seek(int64_t frame);
    // The next frame's chunk and group, checked but not decoded: info() and group() describe it
    // (`tesswave info`), at a cost of reading its bytes. A decoder that has skimmed cannot decode
    // afterwards (read() and seek() throw Error).
    bool skim();
    const std::string& damage() const { return damage_; }

    // Of the frame read last; its mesh's vertices in the frame's pixels (on a canvas, they reach
    // past the frame).
    const TwvFrameInfo& info() const { return info_; }
    const TwvGroup& group() const { return group_; }
    std::span<const Vec2> vertices() const { return vertices_; }
    const Mesh* mesh() const {
        return domain_ && domain_->is_mesh() ? &domain_->shape().mesh : nullptr;
    }

  private:
    struct Chunk {
        uint8_t tag = 0;
        std::vector<uint8_t> payload;
        uint64_t offset = 0, end = 0;
    };
    std::optional<Chunk> read_chunk(uint64_t offset);
    void read_index();
    void start_group(const Chunk& chunk);
    void decode_frame(const Chunk& chunk, Image* out);
    bool next_frame(Image* out, bool decode);
    void describe_frame(const Chunk& chunk);
    // Checks a frame chunk's number and kind against the group (`slot`: the chunks of the group
    // before it); throws Error.
    TwvFrame frame_of(const Chunk& chunk, const std::string& what, int64_t slot) const;
    // Hands out a copy of the frame before (a repeat); renders it if it was not.
    void repeat_frame(Image* out);
    std::vector<Vec2> frame_vertices(const TwvFrame& f, const std::string& what,
                                     int64_t slot) const;
    void load_lifted_group();
    void charge(int64_t frames, const std::string& what);
    bool skimmed_ = false;
    int64_t work_ = 0;  // frame pixels decoded since the start or the last seek

    // A lifted group, read whole: each frame's coefficients, vertices, description and chunk end.
    struct Lifted {
        std::vector<Planes> coefficients;
        std::vector<std::vector<Vec2>> vertices;
        std::vector<TwvFrameInfo> info;
        std::vector<uint64_t> ends;
        size_t next = 0;     // the next frame to hand out
        std::string damage;  // why the group ended early (after its received frames)
        // Frames [rendered, rendered + images.size()), rendered together, one per core.
        size_t rendered = 0;
        std::vector<Image> images;
    };
    std::optional<Lifted> lifted_;

    std::string path_;
    TwvLimits limits_;
    std::unique_ptr<ByteSource> source_;
    uint64_t file_size_ = 0, header_bytes_ = 0, data_end_ = 0, position_ = 0;
    TwvHeader header_;
    std::optional<TwvIndex> index_;
    TwvGroup group_;
    std::shared_ptr<const CodingDomain> domain_;
    bool in_group_ = false;
    int64_t group_chunks_ = 0;  // frame chunks of the group read so far
    // Copies still to hand out of the frame read last, and its image when it was rendered.
    int64_t repeats_left_ = 0;
    std::optional<Image> repeated_;
    int64_t next_frame_ = 0;  // the frame number the next frame chunk must carry
    Planes coefficients_;
    std::vector<Vec2> vertices_, previous_;  // this frame's and the one before (empty: none)
    TwvFrameInfo info_;
    std::string damage_;
};

}  // namespace tesswave::video
