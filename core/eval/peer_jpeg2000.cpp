#include "core/eval/peer_jpeg2000.h"

#include <openjpeg.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

constexpr int kMaxLevels = OPJ_J2K_MAXRLVLS - 1;
constexpr int kMaxEncodes = 12;

// ---- OpenJPEG plumbing: owners, messages, memory streams -------------------------------------

struct CodecDeleter {
    void operator()(opj_codec_t* codec) const { opj_destroy_codec(codec); }
};
struct StreamDeleter {
    void operator()(opj_stream_t* stream) const { opj_stream_destroy(stream); }
};
struct ImageDeleter {
    void operator()(opj_image_t* image) const { opj_image_destroy(image); }
};
using CodecPtr = std::unique_ptr<opj_codec_t, CodecDeleter>;
using StreamPtr = std::unique_ptr<opj_stream_t, StreamDeleter>;
using ImagePtr = std::unique_ptr<opj_image_t, ImageDeleter>;

// OpenJPEG's errors, kept for the exception; its warnings and information are dropped.
struct Messages {
    std::string errors;
};

void on_error(const char* message, void* data) {
    auto* messages = static_cast<Messages*>(data);
    std::string text = message ? message : "";
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    if (text.empty() || messages->errors.size() > 1000) return;
    if (!messages->errors.empty()) messages->errors += "; ";
    messages->errors += text;
}

void on_ignored(const char*, void*) {}

void set_handlers(opj_codec_t* codec, Messages& messages) {
    opj_set_info_handler(codec, on_ignored, nullptr);
    opj_set_warning_handler(codec, on_ignored, nullptr);
    opj_set_error_handler(codec, on_error, &messages);
}

[[noreturn]] void fail(const char* what, const Messages& messages) {
    throw Error(str("JPEG 2000: ", what, messages.errors.empty() ? "" : ": ", messages.errors));
}

// The callbacks run inside C code: no exception may leave them.
struct Sink {
    std::vector<uint8_t> bytes;
    size_t position = 0;
};

OPJ_SIZE_T sink_write(void* buffer, OPJ_SIZE_T count, void* data) {
    auto* sink = static_cast<Sink*>(data);
    try {
        const size_t end = sink->position + count;
        if (end > sink->bytes.size()) sink->bytes.resize(end);
        std::memcpy(sink->bytes.data() + sink->position, buffer, count);
        sink->position = end;
        return count;
    } catch (...) {
        return static_cast<OPJ_SIZE_T>(-1);
    }
}

OPJ_OFF_T sink_skip(OPJ_OFF_T count, void* data) {
    auto* sink = static_cast<Sink*>(data);
    const OPJ_OFF_T position = static_cast<OPJ_OFF_T>(sink->position) + count;
    if (position < 0) return -1;
    sink->position = static_cast<size_t>(position);  // past the end: the next write zero-fills
    return count;
}

OPJ_BOOL sink_seek(OPJ_OFF_T position, void* data) {
    if (position < 0) return OPJ_FALSE;
    static_cast<Sink*>(data)->position = static_cast<size_t>(position);
    return OPJ_TRUE;
}

struct Source {
    std::span<const uint8_t> bytes;
    size_t position = 0;
};

OPJ_SIZE_T source_read(void* buffer, OPJ_SIZE_T count, void* data) {
    auto* source = static_cast<Source*>(data);
    const size_t left = source->bytes.size() - source->position;
    if (left == 0) return static_cast<OPJ_SIZE_T>(-1);
    const size_t n = std::min<size_t>(count, left);
    std::memcpy(buffer, source->bytes.data() + source->position, n);
    source->position += n;
    return n;
}

OPJ_OFF_T source_skip(OPJ_OFF_T count, void* data) {
    auto* source = static_cast<Source*>(data);
    const auto position = static_cast<OPJ_OFF_T>(source->position);
    const auto size = static_cast<OPJ_OFF_T>(source->bytes.size());
    const OPJ_OFF_T target = std::clamp<OPJ_OFF_T>(position + count, 0, size);
    source->position = static_cast<size_t>(target);
    return target - position;
}

OPJ_BOOL source_seek(OPJ_OFF_T position, void* data) {
    auto* source = static_cast<Source*>(data);
    if (position < 0 || static_cast<uint64_t>(position) > source->bytes.size()) return OPJ_FALSE;
    source->position = static_cast<size_t>(position);
    return OPJ_TRUE;
}

// ---- Encoder -----------------------------------------------------------------------------------

// round(v * 255) in float, halves away from zero, clamped; NaN gives 0 (as metrics.cpp).
int32_t quantize(float v) {
    const float s = std::round(v * 255.0f);
    if (!(s > 0.0f)) return 0;
    return s >= 255.0f ? 255 : static_cast<int32_t>(s);
}

void check_encodable(const Image& image, const Jpeg2000Options& options) {
    if (image.width < 1 || image.height < 1) {
        throw Error(str("JPEG 2000: empty image (", image.width, "x", image.height, ")"));
    }
    if (image.channels() < 1 || image.channels() > 4) {
        throw Error(str("JPEG 2000: ", image.channels(), " channels; 1 to 4 are supported"));
    }
    const size_t pixels = static_cast<size_t>(image.width) * image.height;
    for (int c = 0; c < image.channels(); ++c) {
        if (image.planes[c].size() != pixels) {
            throw Error(str("JPEG 2000: plane ", c, " has ", image.planes[c].size(),
                            " samples, not ", image.width, "x", image.height));
        }
    }
    if (options.target_bytes < 0) {
        throw Error(str("JPEG 2000: negative target_bytes ", options.target_bytes));
    }
    if (options.levels < 0 || options.levels > kMaxLevels) {
        throw Error(str("JPEG 2000: levels ", options.levels, " is outside 0..", kMaxLevels));
    }
}

// OpenJPEG takes the sample data over (opj_start_compress moves it), so each encode gets its own.
ImagePtr make_opj_image(const std::vector<std::vector<int32_t>>& planes, int width, int height) {
    const int channels = static_cast<int>(planes.size());
    std::vector<opj_image_cmptparm_t> params(channels);
    for (auto& p : params) {
        p = {};
        p.dx = p.dy = 1;
        p.w = static_cast<OPJ_UINT32>(width);
        p.h = static_cast<OPJ_UINT32>(height);
        p.prec = 8;
        p.sgnd = 0;
    }
    const OPJ_COLOR_SPACE space = channels >= 3 ? OPJ_CLRSPC_SRGB : OPJ_CLRSPC_GRAY;
    ImagePtr image(opj_image_create(static_cast<OPJ_UINT32>(channels), params.data(), space));
    if (!image) throw Error("JPEG 2000: out of memory for the image");
    image->x0 = image->y0 = 0;
    image->x1 = static_cast<OPJ_UINT32>(width);
    image->y1 = static_cast<OPJ_UINT32>(height);
    for (int c = 0; c < channels; ++c) {
        std::copy(planes[c].begin(), planes[c].end(), image->comps[c].data);
    }
    return image;
}

struct EncodeSettings {
    bool lossless = true;
    float ratio = 0;  // raw bytes / codestream budget; <= 1 leaves every pass in (no truncation)
    int levels = 5;
};

std::vector<uint8_t> encode_once(const std::vector<std::vector<int32_t>>& planes, int width,
                                 int height, const EncodeSettings& settings) {
    opj_cparameters_t params;
    opj_set_default_encoder_parameters(&params);
    params.tcp_numlayers = 1;
    params.cp_disto_alloc = 1;
    params.tcp_rates[0] = settings.lossless ? 0.0f : settings.ratio;
    params.irreversible = settings.lossless ? 0 : 1;
    params.numresolution = settings.levels + 1;
    params.tcp_mct = planes.size() >= 3 ? 1 : 0;
    char empty_comment[] = "";
    params.cp_comment = empty_comment;

    ImagePtr image = make_opj_image(planes, width, height);
    Messages messages;
    CodecPtr codec(opj_create_compress(OPJ_CODEC_J2K));
    if (!codec) throw Error("JPEG 2000: cannot create the OpenJPEG encoder");
    set_handlers(codec.get(), messages);
    if (!opj_setup_encoder(codec.get(), &params, image.get())) fail("encoder setup", messages);
    opj_codec_set_threads(codec.get(), 0);

    Sink sink;
    StreamPtr stream(opj_stream_create(OPJ_J2K_STREAM_CHUNK_SIZE, OPJ_FALSE));
    if (!stream) throw Error("JPEG 2000: cannot create an OpenJPEG stream");
    opj_stream_set_write_function(stream.get(), sink_write);
    opj_stream_set_skip_function(stream.get(), sink_skip);
    opj_stream_set_seek_function(stream.get(), sink_seek);
    opj_stream_set_user_data(stream.get(), &sink, nullptr);
    if (!opj_start_compress(codec.get(), image.get(), stream.get()) ||
        !opj_encode(codec.get(), stream.get()) || !opj_end_compress(codec.get(), stream.get())) {
        fail("encoding failed", messages);
    }
    stream.reset();  // flushes OpenJPEG's buffer into the sink
    return std::move(sink.bytes);
}

int usable_levels(int levels, int width, int height) {
    int fit = 0;
    while (fit < levels && (std::min(width, height) >> (fit + 1)) >= 1) ++fit;
    return fit;
}

// OpenJPEG 2.5 turns the ratio back into a budget in bytes, takes off the main header it has
// written, and fills the packets up to that budget rounded up; the SOT and SOD markers (14 bytes)
// and EOC (2) come on top. A budget of target - 16.5 therefore yields, in one encode, the largest
// codestream <= target that its rate allocator can make.
constexpr double kUnbudgetedBytes = 16.5;

// The bracket of a search on the budget, for an OpenJPEG that counts otherwise: the largest budget
// known to fit the target and the smallest known to overflow it, with their sizes.
struct Bracket {
    double target = 0;
    double lo = 0, lo_size = 0;
    double hi = HUGE_VAL, hi_size = 0;
    double step = 0;  // of the last one-sided move; doubles until the target is bracketed
    bool bisect = false;

    // Sizes follow budgets almost one for one, so a move by the missing bytes usually lands;
    // inside a bracket, interpolation alternates with bisection so that the bracket at least
    // halves every two encodes.
    double next(double budget, double size) {
        if (hi == HUGE_VAL || lo == 0) {
            step = std::max(std::abs(budget * (target / size - 1.0)), 2.0 * step);
            return hi == HUGE_VAL ? budget + step : budget - step;
        }
        bisect = !bisect;
        if (bisect || hi_size <= lo_size) return 0.5 * (lo + hi);
        return lo + (hi - lo) * std::clamp((target - lo_size) / (hi_size - lo_size), 0.1, 0.9);
    }
};

// The largest codestream <= target. The budget b goes to OpenJPEG as the ratio raw / b. Its rate
// allocator keeps, in every code-block, the passes whose distortion-rate slope passes one
// threshold, so the sizes it can make are steps apart (typically 50 to 300 bytes on a 768x512
// photograph at 0.25 to 1 bpp) and no budget gets closer to the target than the step below it.
std::vector<uint8_t> encode_to_size(const std::vector<std::vector<int32_t>>& planes, int width,
                                    int height, int levels, int64_t target_bytes) {
    const double raw = static_cast<double>(width) * height * static_cast<double>(planes.size());
    const auto target = static_cast<double>(target_bytes);
    const double tolerance = std::max(8.0, 0.001 * target);
    Bracket bracket{.target = target};
    std::vector<uint8_t> best;
    double budget = target - kUnbudgetedBytes;
    for (int i = 0; i < kMaxEncodes && budget >= 1.0 && bracket.hi - bracket.lo > 1.0; ++i) {
        const float ratio = static_cast<float>(raw / budget);
        std::vector<uint8_t> bytes = encode_once(planes, width, height, {false, ratio, levels});
        const auto size = static_cast<double>(bytes.size());
        if (size <= target) {
            bracket.lo = budget;
            bracket.lo_size = size;
            if (bytes.size() > best.size()) best = std::move(bytes);
            // At a ratio <= 1 OpenJPEG keeps every pass: no larger budget changes anything.
            if (i == 0 || ratio <= 1.0f || target - size <= tolerance) break;
        } else {
            bracket.hi = budget;
            bracket.hi_size = size;
        }
        budget = bracket.next(budget, size);
    }
    if (best.empty()) {
        // Budget 1 byte: headers and empty packets, the smallest codestream OpenJPEG writes.
        std::vector<uint8_t> smallest =
            encode_once(planes, width, height, {false, static_cast<float>(raw), levels});
        if (static_cast<double>(smallest.size()) <= target) return smallest;
        throw Error(str("JPEG 2000: target_bytes ", target_bytes, " is below the smallest ",
                        "codestream of this image (", smallest.size(), " bytes)"));
    }
    return best;
}

// ---- Decoder -----------------------------------------------------------------------------------

std::optional<OPJ_CODEC_FORMAT> detect_format(std::span<const uint8_t> bytes) {
    static constexpr uint8_t kJ2k[] = {0xFF, 0x4F, 0xFF, 0x51};
    static constexpr uint8_t kJp2[] = {0x00, 0x00, 0x00, 0x0C, 0x6A, 0x50,
                                       0x20, 0x20, 0x0D, 0x0A, 0x87, 0x0A};
    auto starts_with = [&](std::span<const uint8_t> magic) {
        return bytes.size() >= magic.size() &&
               std::equal(magic.begin(), magic.end(), bytes.begin());
    };
    if (starts_with(kJ2k)) return OPJ_CODEC_J2K;
    if (starts_with(kJp2)) return OPJ_CODEC_JP2;
    return std::nullopt;
}

// Components as decoded (after any JP2 palette): all the image's size, unsigned, 1..16 bits.
void check_decoded(const opj_image_t& image, bool after_decode) {
    if (image.numcomps < 1 || image.numcomps > 4) {
        throw Error(str("JPEG 2000: ", image.numcomps, " components; 1 to 4 are supported"));
    }
    const opj_image_comp_t& first = image.comps[0];
    for (OPJ_UINT32 c = 0; c < image.numcomps; ++c) {
        const opj_image_comp_t& comp = image.comps[c];
        if (comp.dx != 1 || comp.dy != 1 || comp.w != first.w || comp.h != first.h) {
            throw Error(str("JPEG 2000: component ", c, " is subsampled; not supported"));
        }
        if (comp.sgnd || comp.prec < 1 || comp.prec > 16) {
            throw Error(str("JPEG 2000: component ", c, " has ", comp.sgnd ? "signed " : "",
                            comp.prec, "-bit samples; unsigned 1 to 16 bits are supported"));
        }
        if (after_decode && !comp.data) throw Error("JPEG 2000: a component was not decoded");
    }
    const uint64_t samples = uint64_t{first.w} * first.h * image.numcomps;
    if (first.w < 1 || first.h < 1 || samples > static_cast<uint64_t>(kJpeg2000MaxSamples)) {
        throw Error(str("JPEG 2000: image of ", first.w, "x", first.h, "x", image.numcomps,
                        " samples is outside the limit of ", kJpeg2000MaxSamples));
    }
}

Image to_image(const opj_image_t& decoded) {
    const opj_image_comp_t& first = decoded.comps[0];
    const int width = static_cast<int>(first.w), height = static_cast<int>(first.h);
    OPJ_UINT32 max_prec = 0;
    for (OPJ_UINT32 c = 0; c < decoded.numcomps; ++c) {
        max_prec = std::max(max_prec, decoded.comps[c].prec);
    }
    Image image = make_image(width, height, static_cast<int>(decoded.numcomps),
                             max_prec <= 8 ? SampleFormat::u8 : SampleFormat::u16);
    for (OPJ_UINT32 c = 0; c < decoded.numcomps; ++c) {
        const opj_image_comp_t& comp = decoded.comps[c];
        const int32_t peak = (int32_t{1} << comp.prec) - 1;
        const auto scale = static_cast<float>(peak);
        std::vector<float>& plane = image.planes[c];
        for (size_t i = 0; i < plane.size(); ++i) {
            plane[i] = static_cast<float>(std::clamp<int32_t>(comp.data[i], 0, peak)) / scale;
        }
    }
    return image;
}

}  // namespace

std::vector<uint8_t> encode_jpeg2000(const Image& image, const Jpeg2000Options& options) {
    check_encodable(image, options);
    std::vector<std::vector<int32_t>> planes(image.channels());
    for (int c = 0; c < image.channels(); ++c) {
        planes[c].resize(image.planes[c].size());
        std::transform(image.planes[c].begin(), image.planes[c].end(), planes[c].begin(), quantize);
    }
    const int levels = usable_levels(options.levels, image.width, image.height);
    if (options.target_bytes == 0) {
        return encode_once(planes, image.width, image.height, {true, 0.0f, levels});
    }
    return encode_to_size(planes, image.width, image.height, levels, options.target_bytes);
}

Image decode_jpeg2000(std::span<const uint8_t> bytes) {
    const std::optional<OPJ_CODEC_FORMAT> format = detect_format(bytes);
    if (!format) throw Error("JPEG 2000: neither a J2K codestream nor a JP2 file");

    Messages messages;
    CodecPtr codec(opj_create_decompress(*format));
    if (!codec) throw Error("JPEG 2000: cannot create the OpenJPEG decoder");
    set_handlers(codec.get(), messages);
    opj_dparameters_t params;
    opj_set_default_decoder_parameters(&params);
    if (!opj_setup_decoder(codec.get(), &params) ||
        !opj_decoder_set_strict_mode(codec.get(), OPJ_FALSE)) {
        fail("decoder setup", messages);
    }
    opj_codec_set_threads(codec.get(), 0);

    Source source{bytes};
    StreamPtr stream(opj_stream_create(OPJ_J2K_STREAM_CHUNK_SIZE, OPJ_TRUE));
    if (!stream) throw Error("JPEG 2000: cannot create an OpenJPEG stream");
    opj_stream_set_read_function(stream.get(), source_read);
    opj_stream_set_skip_function(stream.get(), source_skip);
    opj_stream_set_seek_function(stream.get(), source_seek);
    opj_stream_set_user_data(stream.get(), &source, nullptr);
    opj_stream_set_user_data_length(stream.get(), bytes.size());

    opj_image_t* raw_image = nullptr;
    const bool header_ok = opj_read_header(stream.get(), codec.get(), &raw_image);
    ImagePtr image(raw_image);
    if (!header_ok || !image) fail("bad header", messages);
    check_decoded(*image, false);
    if (!opj_decode(codec.get(), stream.get(), image.get()) ||
        !opj_end_decompress(codec.get(), stream.get())) {
        fail("decoding failed", messages);
    }
    check_decoded(*image, true);
    return to_image(*image);
}

}  // namespace tesswave
