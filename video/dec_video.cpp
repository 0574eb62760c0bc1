#include "dec_video.h"

#include <algorithm>

#include "core/codec/byte_io.h"
#include "core/math/error.h"
#include "core/math/parallel.h"
#include "core/math/strings.h"
#include "mesh_motion.h"

namespace tesswave::video {
namespace {

// Whether two groups code alike (motion and the lifted length aside): the domain can be kept.
bool same_domain(const TwvGroup& a, const TwvGroup& b) {
    return a.transform == b.transform && a.levels == b.levels && a.grid_cols == b.grid_cols &&
           a.grid_rows == b.grid_rows && a.mesh_wavelet == b.mesh_wavelet &&
           a.extend_x == b.extend_x && a.extend_y == b.extend_y &&
           a.channel_factors == b.channel_factors && a.band_norms == b.band_norms;
}

}  // namespace

VideoDecoder::VideoDecoder(const std::string& path, const TwvLimits& limits)
    : VideoDecoder(file_source(path), path, limits) {}

VideoDecoder::VideoDecoder(std::unique_ptr<ByteSource> source, const std::string& name,
                           const TwvLimits& limits)
    : path_(name), limits_(limits), source_(std::move(source)) {
    file_size_ = source_->size();
    std::vector<uint8_t> head(std::min<uint64_t>(file_size_, 64));
    if (!source_->read(0, head)) throw Error(str(name, ": cannot read"));
    size_t used = 0;
    header_ = read_twv_header(head, name, used, limits);
    const int64_t needed = twv_bytes_needed(int64_t{header_.width} * header_.height, limits);
    if (static_cast<int64_t>(file_size_) < needed) {
        throw Error(str(name, ": ", header_.width, "x", header_.height, " frames in a ", file_size_,
                        "-byte file (a file needs ", needed,
                        " bytes to claim frames that large; --max-pixels raises the limit)"));
    }
    position_ = header_bytes_ = used;
    data_end_ = file_size_;
    read_index();
}

VideoDecoder::~VideoDecoder() = default;

std::optional<int64_t> VideoDecoder::frame_count() const {
    if (!index_) return std::nullopt;
    return static_cast<int64_t>(index_->frame_offsets.size());
}

std::optional<int64_t> VideoDecoder::group_count() const {
    if (!index_) return std::nullopt;
    return static_cast<int64_t>(index_->group_offsets.size());
}

// The trailer names the index chunk; a missing or damaged one leaves the file to be scanned.
void VideoDecoder::read_index() {
    if (file_size_ < position_ + kTwvTrailerBytes) return;
    uint8_t t[kTwvTrailerBytes];
    if (!source_->read(file_size_ - kTwvTrailerBytes, t) ||
        !std::equal(t + 8, t + 12, kTwvTrailerMagic)) {
        return;
    }
    uint64_t offset = 0;
    for (int i = 7; i >= 0; --i) offset = (offset << 8) | t[i];
    if (offset < position_ || offset >= file_size_ - kTwvTrailerBytes) return;
    const uint64_t saved_end = data_end_;
    data_end_ = file_size_ - kTwvTrailerBytes;
    std::optional<Chunk> chunk = read_chunk(offset);
    data_end_ = saved_end;
    damage_.clear();
    if (!chunk || chunk->tag != 'I' || chunk->end != file_size_ - kTwvTrailerBytes) return;
    try {
        index_ =
            read_twv_index(chunk->payload, offset, str(path_, ": index"), limits_, header_.version);
        data_end_ = offset;
    } catch (const Error&) {
        index_.reset();
    }
}

std::optional<VideoDecoder::Chunk> VideoDecoder::read_chunk(uint64_t offset) {
    if (offset >= data_end_) return std::nullopt;
    const auto fail = [&](const std::string& why) {
        damage_ = str(path_, ": ", why, " at byte ", offset);
        return std::nullopt;
    };
    ByteWriter head;  // tag and size bytes, for the CRC
    uint8_t byte = 0;
    uint64_t size = 0;
    for (int i = 0; i < 11; ++i) {
        if (offset + head.size() >= data_end_ ||
            !source_->read(offset + head.size(), std::span(&byte, 1))) {
            return fail("truncated chunk");
        }
        head.u8(byte);
        if (i == 0) continue;
        if (i == 10) return fail("bad chunk size");
        size |= uint64_t{byte & 0x7Fu} << (7 * (i - 1));
        if (!(byte & 0x80)) break;
    }
    const uint64_t start = offset + head.size();
    if (size > static_cast<uint64_t>(limits_.max_chunk_bytes)) {
        return fail(str("chunk of ", size, " bytes exceeds the limit"));
    }
    if (size + 4 > data_end_ - start) return fail("truncated chunk");
    Chunk chunk;
    chunk.tag = head.data()[0];
    chunk.offset = offset;
    chunk.end = start + size + 4;
    chunk.payload.resize(size);
    uint8_t crc_bytes[4];
    if (!source_->read(start, chunk.payload) || !source_->read(start + size, crc_bytes)) {
        return fail("truncated chunk");
    }
    const uint32_t crc = uint32_t{crc_bytes[0]} | uint32_t{crc_bytes[1]} << 8 |
                         uint32_t{crc_bytes[2]} << 16 | uint32_t{crc_bytes[3]} << 24;
    if (crc != crc32(chunk.payload, crc32(head.data())))
        return fail("damaged chunk (CRC mismatch)");
    return chunk;
}

void VideoDecoder::start_group(const Chunk& chunk) {
    TwvGroup g = read_twv_group(chunk.payload, header_, str(path_, ": group"), limits_);
    const int64_t samples = twv_group_samples(g),
                  allowed = twv_samples_allowed(static_cast<int64_t>(file_size_), limits_);
    if (samples > allowed) {
        throw Error(str(path_, ": group at frame ", g.first_frame, ": its mesh has ", samples,
                        " samples, more than the ", allowed, " a ", file_size_,
                        "-byte file may claim (--max-pixels raises the limit)"));
    }
    if (g.first_frame != next_frame_) {
        throw Error(
            str(path_, ": group starts at frame ", g.first_frame, ", expected ", next_frame_));
    }
    if (skimmed_) {  // described, not decoded: no domain
        group_ = std::move(g);
        in_group_ = true;
        group_chunks_ = 0;
        return;
    }
    if (!domain_ || !same_domain(g, group_)) domain_ = group_domain(header_, g, false);
    group_ = std::move(g);
    in_group_ = true;
    group_chunks_ = 0;
}

TwvFrame VideoDecoder::frame_of(const Chunk& chunk, const std::string& what, int64_t slot) const {
    if (!in_group_) throw Error(str(what, " comes before any group"));
    TwvFrame f = read_twv_frame(chunk.payload, group_, header_, what);
    if (f.number != next_frame_) throw Error(str(what, ": the chunk says frame ", f.number));
    const bool first = next_frame_ == group_.first_frame;
    if (group_.lifted > 0) {
        if (slot >= group_.lifted) {
            throw Error(str(what, " lies past its group's ", group_.lifted, " frames"));
        }
    } else if (first != (f.kind == TwvFrameKind::intra)) {
        throw Error(str(what, first ? " must be an intra frame" : " is an unexpected intra frame"));
    }
    return f;
}

// The frame's vertex positions from its motion and the frames before (vertices_, previous_).
// By the frame's slot in its group, not its number: repeated frames carry no motion.
std::vector<Vec2> VideoDecoder::frame_vertices(const TwvFrame& f, const std::string& what,
                                               int64_t slot) const {
    if (!domain_->is_mesh()) return {};
    const std::vector<Vec2>& rest = domain_->shape().mesh.vertices;
    if (group_.motion != TwvMotion::tracked) return rest;
    const bool first = slot == 0;
    const bool two_back = slot >= 2;
    const std::vector<Vec2>& from = first ? rest : vertices_;
    if (f.motion.empty()) return from;
    return decode_motion(f.motion, from,
                         two_back ? std::span<const Vec2>(previous_) : std::span<const Vec2>(),
                         domain_->shape().mesh, what, header_.version >= 2);
}

// Counts `frames` frames of decoding against what the file's size allows (TwvLimits); throws
// Error before the work when it would go past it.
void VideoDecoder::charge(int64_t frames, const std::string& what) {
    const int64_t pixels = twv_frame_work(int64_t{header_.width} * header_.height) * frames;
    const int64_t allowed = twv_work_allowed(static_cast<int64_t>(file_size_), limits_);
    if (pixels > allowed - work_) {
        throw Error(str(what, ": decoding would pass the ", allowed, " frame pixels that a ",
                        file_size_, "-byte file may cost (--max-pixels raises the limit)"));
    }
    work_ += pixels;
}

void VideoDecoder::decode_frame(const Chunk& chunk, Image* out) {
    const std::string what = str(path_, ": frame ", next_frame_);
    charge(1, what);
    const int64_t slot = group_chunks_++;
    TwvFrame f = frame_of(chunk, what, slot);
    std::vector<Vec2> vertices = frame_vertices(f, what, slot);
    if (next_frame_ == group_.first_frame) coefficients_ = domain_->zeros();
    add_decoded_residual(*domain_, f, coefficients_, header_.version);
    previous_ = std::move(vertices_);
    vertices_ = std::move(vertices);
    info_ = {.number = f.number,
             .kind = f.kind,
             .bytes = static_cast<int64_t>(chunk.end - chunk.offset),
             .motion_bytes = static_cast<int64_t>(f.motion.size()),
             .repeats = f.repeats};
    if (out) domain_->synthesize(coefficients_, vertices_, *out);
    repeats_left_ = f.repeats;
    repeated_.reset();
    if (out && f.repeats > 0) repeated_ = *out;
    ++next_frame_;
}

void VideoDecoder::repeat_frame(Image* out) {
    charge(1, str(path_, ": frame ", next_frame_));
    --repeats_left_;
    info_ = {.number = next_frame_, .kind = info_.kind, .repeat = true};
    if (out) {
        if (!repeated_) {  // the frame was skipped (a seek): render it now
            Image image;
            if (lifted_) {
                const size_t t = lifted_->next - 1;
                std::vector<Image> one(1);
                synthesize_frames(*domain_, std::span(lifted_->coefficients).subspan(t, 1),
                                  std::span(lifted_->vertices).subspan(t, 1), one);
                image = std::move(one[0]);
            } else {
                domain_->synthesize(coefficients_, vertices_, image);
            }
            repeated_ = std::move(image);
        }
        *out = *repeated_;
    }
    ++next_frame_;
}

// Reads the chunks of the lifted group that starts at position_ (without moving position_), as
// many as arrive intact, and inverts the temporal transform.
void VideoDecoder::load_lifted_group() {
    const std::string group_what = str(path_, ": group at frame ", next_frame_);
    const int64_t group_bytes = twv_lifted_group_bytes(group_, header_);
    const int64_t group_allowed =
        twv_group_bytes_allowed(static_cast<int64_t>(file_size_), limits_);
    if (group_bytes > group_allowed) {
        throw Error(str(group_what, ": its ", group_.lifted, " frames take ", group_bytes,
                        " bytes of coefficients, more than the ", group_allowed, " a ", file_size_,
                        "-byte file may claim (--max-pixels raises the limit)"));
    }
    charge(group_.lifted, group_what);
    Lifted g;
    std::vector<TwvFrame> bands;
    const int64_t saved_next = next_frame_;
    uint64_t at = position_;
    for (int t = 0; t < group_.lifted; ++t) {
        const std::string what = str(path_, ": frame ", next_frame_);
        std::optional<Chunk> chunk = read_chunk(at);
        if (!chunk) {
            // A clean end right after the group chunk is a clip that ends there, as in a low-delay
            // group; an end after some of its frames cuts the group short.
            if (!damage_.empty() || t > 0) {
                g.damage =
                    damage_.empty() ? str(what, ": the file ends inside its group") : damage_;
            }
            damage_.clear();
            break;
        }
        try {
            if (chunk->tag != 'F') {
                throw Error(
                    str(what, ": the group ends after ", t, " of its ", group_.lifted, " frames"));
            }
            TwvFrame f = frame_of(*chunk, what, t);
            std::vector<Vec2> vertices = frame_vertices(f, what, t);
            previous_ = std::move(vertices_);
            vertices_ = vertices;  // on the canvas: what the next frame's motion starts from
            g.vertices.push_back(group_.has_canvas() ? window_vertices(vertices, f)
                                                     : std::move(vertices));
            g.info.push_back({.number = f.number,
                              .kind = f.kind,
                              .bytes = static_cast<int64_t>(chunk->end - chunk->offset),
                              .motion_bytes = static_cast<int64_t>(f.motion.size()),
                              .repeats = f.repeats});
            g.ends.push_back(chunk->end);
            next_frame_ += 1 + f.repeats;
            bands.push_back(std::move(f));
        } catch (const Error& e) {
            g.damage = e.what();
            break;
        }
        at = chunk->end;
    }
    next_frame_ = saved_next;
    if (!bands.empty())
        g.coefficients = decode_lifted_group(*domain_, bands, group_.lifted, temporal_tree(header_),
                                             header_.version);
    lifted_ = std::move(g);
}

bool VideoDecoder::read(Image& out, bool render) {
    if (skimmed_) throw Error(str(path_, ": a decoder that has skimmed cannot decode"));
    return next_frame(render ? &out : nullptr, true);
}

bool VideoDecoder::skim() {
    skimmed_ = true;
    return next_frame(nullptr, false);
}

bool VideoDecoder::next_frame(Image* out, bool decode) {
    if (!damage_.empty()) return false;
    try {
        if (repeats_left_ > 0) {
            repeat_frame(out);
            return true;
        }
        for (;;) {
            if (lifted_) {  // hand out the group's next frame
                Lifted& g = *lifted_;
                if (g.next < g.ends.size()) {
                    const size_t t = g.next++;
                    info_ = g.info[t];
                    vertices_ = g.vertices[t];
                    previous_ = t > 0 ? g.vertices[t - 1] : std::vector<Vec2>{};
                    if (out) {
                        if (t < g.rendered || t >= g.rendered + g.images.size()) {
                            // This frame and the next ones, a frame per core, holding at
                            // most 256 MiB of frames ahead (at least this one).
                            const int64_t frame_bytes = int64_t{header_.width} * header_.height *
                                                        header_.channels *
                                                        static_cast<int64_t>(sizeof(float));
                            const size_t count =
                                std::min({static_cast<size_t>(std::max(thread_count(), 1)),
                                          g.ends.size() - t,
                                          static_cast<size_t>(std::max<int64_t>(
                                              1, (int64_t{256} << 20) / frame_bytes))});
                            g.rendered = t;
                            g.images.resize(count);
                            synthesize_frames(*domain_, std::span(g.coefficients).subspan(t, count),
                                              std::span(g.vertices).subspan(t, count), g.images);
                        }
                        *out = std::move(g.images[t - g.rendered]);
                    }
                    repeats_left_ = info_.repeats;
                    repeated_.reset();
                    if (out && info_.repeats > 0) repeated_ = *out;
                    position_ = g.ends[t];
                    ++next_frame_;
                    return true;
                }
                const std::string why = g.damage;
                lifted_.reset();
                in_group_ = false;  // a group's frames end with it
                if (!why.empty()) {
                    damage_ = why;
                    return false;
                }
            }
            std::optional<Chunk> chunk = read_chunk(position_);
            if (!chunk) return false;
            if (chunk->tag == 'I') return false;  // an index whose trailer was cut off
            if (chunk->tag == 'P') {              // padding
                position_ = chunk->end;
                continue;
            }
            if (chunk->tag == 'G') {
                start_group(*chunk);
                position_ = chunk->end;
                if (decode && group_.lifted > 0) load_lifted_group();
                continue;
            }
            if (chunk->tag == 'F') {
                if (decode) {
                    if (group_.lifted > 0) {
                        throw Error(str(path_, ": frame ", next_frame_, " lies past its group"));
                    }
                    decode_frame(*chunk, out);
                } else {
                    describe_frame(*chunk);
                }
                position_ = chunk->end;
                return true;
            }
            throw Error(str(path_, ": unknown chunk '", static_cast<int>(chunk->tag), "' at byte ",
                            chunk->offset));
        }
    } catch (const Error& e) {
        damage_ = e.what();
        return false;
    }
}

void VideoDecoder::describe_frame(const Chunk& chunk) {
    const std::string what = str(path_, ": frame ", next_frame_);
    const TwvFrame f = frame_of(chunk, what, group_chunks_++);
    info_ = {.number = f.number,
             .kind = f.kind,
             .bytes = static_cast<int64_t>(chunk.end - chunk.offset),
             .motion_bytes = static_cast<int64_t>(f.motion.size()),
             .repeats = f.repeats};
    next_frame_ += 1 + f.repeats;
}

bool VideoDecoder::seek(int64_t frame) {
    if (skimmed_) throw Error(str(path_, ": a decoder that has skimmed cannot decode"));
    if (frame < 0) throw Error(str(path_, ": frame ", frame, " does not exist"));
    if (index_) {
        if (frame >= static_cast<int64_t>(index_->frame_offsets.size())) return false;
        const auto& first = index_->group_first;
        const auto it = std::upper_bound(first.begin(), first.end(), frame);
        const size_t g = static_cast<size_t>(it - first.begin()) - 1;
        const bool ahead = in_group_ && group_.first_frame == first[g] && next_frame_ <= frame;
        if (!ahead) {
            position_ = index_->group_offsets[g];
            next_frame_ = first[g];
            in_group_ = false;
            lifted_.reset();
            repeats_left_ = 0;
            damage_.clear();
            work_ = 0;
        }
    } else if (next_frame_ > frame) {
        position_ = header_bytes_;
        next_frame_ = 0;
        in_group_ = false;
        lifted_.reset();
        repeats_left_ = 0;
        damage_.clear();
        work_ = 0;
    }
    Image skipped;
    while (next_frame_ < frame) {
        if (!read(skipped, false)) return false;
    }
    return true;
}

}  // namespace tesswave::video
