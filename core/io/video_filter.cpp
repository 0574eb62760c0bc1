// The libavfilter parts of video_io.h: palette GIFs and the minterpolate in-between peer.
#include <algorithm>
#include <iterator>
#include <string_view>

extern "C" {
#include <libavfilter/avfilter.h>
#include <libavfilter/buffersink.h>
#include <libavfilter/buffersrc.h>
#include <libavutil/pixdesc.h>
}

#include "core/io/video_io.h"
#include "core/io/video_libav.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

struct GraphFree {
    void operator()(AVFilterGraph* graph) const { avfilter_graph_free(&graph); }
};
struct InOutFree {
    void operator()(AVFilterInOut* inout) const { avfilter_inout_free(&inout); }
};

// A configured graph: frames of one size and format go into `source`, come out of `sink`.
struct Graph {
    std::unique_ptr<AVFilterGraph, GraphFree> graph;
    AVFilterContext* source = nullptr;
    AVFilterContext* sink = nullptr;
};

Graph make_graph(const std::string& where, int width, int height, AVPixelFormat format,
                 AVRational frame_rate, const std::string& filters) {
    Graph g;
    g.graph.reset(avfilter_graph_alloc());
    if (!g.graph) throw Error(where + ": out of memory for a filter graph");
    const AVRational time_base = av_inv_q(frame_rate);
    const std::string args =
        str("video_size=", width, "x", height, ":pix_fmt=", av_get_pix_fmt_name(format),
            ":time_base=", time_base.num, "/", time_base.den, ":frame_rate=", frame_rate.num, "/",
            frame_rate.den, ":pixel_aspect=1/1");
    libav::check(avfilter_graph_create_filter(&g.source, avfilter_get_by_name("buffer"), "in",
                                              args.c_str(), nullptr, g.graph.get()),
                 where, "cannot create the filter source");
    libav::check(avfilter_graph_create_filter(&g.sink, avfilter_get_by_name("buffersink"), "out",
                                              nullptr, nullptr, g.graph.get()),
                 where, "cannot create the filter sink");
    // The graph's open input is fed by "in", its open output feeds "out".
    std::unique_ptr<AVFilterInOut, InOutFree> outputs(avfilter_inout_alloc());
    std::unique_ptr<AVFilterInOut, InOutFree> inputs(avfilter_inout_alloc());
    if (!outputs || !inputs) throw Error(where + ": out of memory for a filter graph");
    outputs->name = av_strdup("in");
    outputs->filter_ctx = g.source;
    inputs->name = av_strdup("out");
    inputs->filter_ctx = g.sink;
    AVFilterInOut* in = inputs.release();
    AVFilterInOut* out = outputs.release();
    const int parsed = avfilter_graph_parse_ptr(g.graph.get(), filters.c_str(), &in, &out, nullptr);
    avfilter_inout_free(&in);
    avfilter_inout_free(&out);
    libav::check(parsed, where, str("bad filter graph '", filters, "'"));
    libav::check(avfilter_graph_config(g.graph.get(), nullptr), where,
                 str("cannot configure the filter graph '", filters, "'"));
    return g;
}

void push(Graph& g, const AVFrame* frame, const std::string& where) {
    // KEEP_REF: the graph takes a new reference and the caller keeps its frame.
    libav::check(av_buffersrc_add_frame_flags(g.source, const_cast<AVFrame*>(frame),
                                              AV_BUFFERSRC_FLAG_KEEP_REF),
                 where, "filter graph refused a frame");
}

// Calls `use(frame)` for each frame the sink has ready; true once the sink is at its end.
template <class Use>
bool drain(Graph& g, AVFrame* frame, const std::string& where, Use&& use) {
    for (;;) {
        const int got = av_buffersink_get_frame(g.sink, frame);
        if (got == AVERROR(EAGAIN)) return false;
        if (got == AVERROR_EOF) return true;
        libav::check(got, where, "filtering failed");
        use(frame);
        av_frame_unref(frame);
    }
}

void check_one_of(const std::string& value, std::initializer_list<std::string_view> allowed,
                  const char* what) {
    if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
        throw Error(str(what, " '", value, "' is not one of the allowed values"));
    }
}

void check_frame(const Image& frame, int width, int height, const std::string& where,
                 const char* which) {
    if (frame.width != width || frame.height != height) {
        throw Error(str(where, ": ", which, " is ", frame.width, "x", frame.height,
                        ", the first is ", width, "x", height));
    }
    if (frame.channels() != 1 && frame.channels() != 3 && frame.channels() != 4) {
        throw Error(str(where, ": ", which, " has ", frame.channels(), " channels (1, 3 or 4)"));
    }
}

}  // namespace

// ---- GIF ---------------------------------------------------------------------------------------

std::string gif_filter(const GifOptions& options) {
    check_one_of(options.dither,
                 {"bayer", "heckbert", "floyd_steinberg", "sierra2", "sierra2_4a", "none"},
                 "GIF dither");
    if (options.max_colors < 4 || options.max_colors > 256) {
        throw Error(str("GIF max_colors ", options.max_colors, " is outside 4..256"));
    }
    return str("split[a][b];[a]palettegen=stats_mode=full:max_colors=", options.max_colors,
               ":reserve_transparent=0[p];[b][p]paletteuse=dither=", options.dither);
}

struct GifWriter::State {
    State(const std::string& where, int w, int h, double fps, const GifOptions& options)
        : path(where),
          width(w),
          height(h),
          rate(av_d2q(fps, 1001000)),
          graph(make_graph(path, width, height, AV_PIX_FMT_RGB24, rate, gif_filter(options))),
          output(path, "gif", "gif") {}
    std::string path;
    int width, height;
    AVRational rate;
    Graph graph;
    libav::Output output;
    libav::Frame rgb, paletted;
    int64_t frames = 0;
};

GifWriter::GifWriter(const std::string& path, int width, int height, double fps,
                     const GifOptions& options) {
    libav::silence();
    if (width < 1 || height < 1 || width > 16384 || height > 16384) {
        throw Error(str(path, ": frame size ", width, "x", height, " is outside 1..16384"));
    }
    if (!(fps > 0 && fps <= 100)) throw Error(str(path, ": GIF fps ", fps, " not in (0, 100]"));
    if (options.loop < -1 || options.loop > 65535) {
        throw Error(str(path, ": GIF loop ", options.loop, " is outside -1..65535"));
    }
    state_ = std::make_unique<State>(path, width, height, fps, options);
    State& s = *state_;
    AVCodecContext* enc = s.output.encoder();
    enc->width = av_buffersink_get_w(s.graph.sink);
    enc->height = av_buffersink_get_h(s.graph.sink);
    enc->pix_fmt = static_cast<AVPixelFormat>(av_buffersink_get_format(s.graph.sink));
    enc->time_base = av_buffersink_get_time_base(s.graph.sink);
    enc->framerate = s.rate;
    s.output.open({}, {{"loop", str(options.loop)}});
    s.rgb = libav::alloc_frame(AV_PIX_FMT_RGB24, width, height, path);
    s.paletted.reset(av_frame_alloc());
    if (!s.paletted) throw Error(path + ": out of memory for a frame");
}

GifWriter::~GifWriter() = default;

void GifWriter::write(const Image& frame) {
    State& s = *state_;
    check_frame(frame, s.width, s.height, s.path, str("frame ", s.frames).c_str());
    libav::check(av_frame_make_writable(s.rgb.get()), s.path, "out of memory");
    libav::fill_frame(frame, s.rgb.get());
    s.rgb->pts = s.frames++;
    push(s.graph, s.rgb.get(), s.path);
    // palettegen holds every frame until the end: nothing comes out yet.
    drain(s.graph, s.paletted.get(), s.path, [&](const AVFrame* f) { s.output.send(f); });
}

void GifWriter::finish() {
    State& s = *state_;
    if (s.frames == 0) throw Error(s.path + ": no frames for the GIF");
    libav::check(av_buffersrc_add_frame(s.graph.source, nullptr), s.path,
                 "cannot end the filter input");
    if (!drain(s.graph, s.paletted.get(), s.path, [&](const AVFrame* f) { s.output.send(f); })) {
        throw Error(s.path + ": filter graph stalled");
    }
    s.output.finish();
}

void write_gif(const std::vector<Image>& frames, const std::string& path, double fps,
               const GifOptions& options) {
    if (frames.empty()) throw Error(path + ": no frames for the GIF");
    GifWriter gif(path, frames[0].width, frames[0].height, fps, options);
    for (const Image& frame : frames) gif.write(frame);
    gif.finish();
}

// ---- minterpolate ------------------------------------------------------------------------------

std::string minterpolate_filter(const MinterpolateOptions& o) {
    check_one_of(o.mc_mode, {"obmc", "aobmc"}, "minterpolate mc_mode");
    check_one_of(o.me_mode, {"bilat", "bidir"}, "minterpolate me_mode");
    check_one_of(o.me, {"esa", "tss", "tdls", "ntss", "fss", "ds", "hexbs", "epzs", "umh"},
                 "minterpolate me");
    if (o.mb_size != 4 && o.mb_size != 8 && o.mb_size != 16) {
        throw Error(str("minterpolate mb_size ", o.mb_size, " is not 4, 8 or 16"));
    }
    if (o.search_param < 4 || o.search_param > 1024) {
        throw Error(str("minterpolate search_param ", o.search_param, " is outside 4..1024"));
    }
    return str("format=yuvj444p,minterpolate=fps=2:mi_mode=mci:mc_mode=", o.mc_mode,
               ":me_mode=", o.me_mode, ":me=", o.me, ":mb_size=", o.mb_size,
               ":search_param=", o.search_param, ":vsbmc=", o.vsbmc ? 1 : 0,
               ":scd=", o.scene_change_detection ? "fdiff" : "none", ",format=gbrp");
}

Image minterpolate_middle(const Image& frame0, const Image& frame1,
                          const MinterpolateOptions& options) {
    libav::silence();
    const std::string where = "minterpolate";
    const int width = frame0.width, height = frame0.height;
    check_frame(frame0, width, height, where, "frame0");
    check_frame(frame1, width, height, where, "frame1");
    const std::string filters = minterpolate_filter(options);
    // minterpolate fails on frames narrower or lower than two blocks.
    if (width < 2 * options.mb_size || height < 2 * options.mb_size || width > 16384 ||
        height > 16384) {
        throw Error(str(where, ": frames of ", width, "x", height, " (", 2 * options.mb_size,
                        "..16384 a side with mb_size ", options.mb_size, ")"));
    }
    Graph g = make_graph(where, width, height, AV_PIX_FMT_GBRP, AVRational{1, 1}, filters);
    const AVRational out_base = av_buffersink_get_time_base(g.sink);
    libav::Frame in = libav::alloc_frame(AV_PIX_FMT_GBRP, width, height, where);
    libav::Frame out(av_frame_alloc());
    if (!out) throw Error(where + ": out of memory for a frame");
    Image middle;
    const auto keep_middle = [&](const AVFrame* frame) {
        if (av_compare_ts(frame->pts, out_base, 1, AVRational{1, 2}) == 0) {
            libav::image_from_frame(frame, middle);
        }
    };
    // frame1 twice: minterpolate interpolates between the 2nd and 3rd of the four frames it
    // holds (the first frame fills two slots) and, in FFmpeg 5.1, does not flush at the end.
    for (int64_t pts = 0; pts < 3; ++pts) {
        libav::check(av_frame_make_writable(in.get()), where, "out of memory");
        libav::fill_frame(pts == 0 ? frame0 : frame1, in.get());
        in->pts = pts;
        push(g, in.get(), where);
        drain(g, out.get(), where, keep_middle);
    }
    libav::check(av_buffersrc_add_frame(g.source, nullptr), where, "cannot end the input");
    if (!drain(g, out.get(), where, keep_middle)) throw Error(where + ": filter graph stalled");
    if (middle.width == 0) throw Error(where + ": the filter produced no middle frame");
    return middle;
}

}  // namespace tesswave
