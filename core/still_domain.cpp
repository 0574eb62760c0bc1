#include "still_domain.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "colour.h"
#include "error.h"
#include "fixed_grid.h"
#include "lifting.h"
#include "sampling.h"
#include "strings.h"

namespace tesswave {
namespace {

template <class T>
std::vector<std::span<T>> spans(std::vector<std::vector<T>>& planes) {
    return {planes.begin(), planes.end()};
}

GridWavelet wavelet_of(TwiTransform t) {
    return t == TwiTransform::grid97 ? GridWavelet::cdf97 : GridWavelet::cdf53;
}

float max_value(const TwiHeader& h) { return h.bit_depth == 16 ? 65535.0f : 255.0f; }

}  // namespace

StillDomain::StillDomain(const TwiHeader& header, int probes) : header_(header) {
    const TwiHeader& h = header_;
    if (h.transform != TwiTransform::mesh) {
        layout_ = grid_layout(h.width, h.height, h.levels, wavelet_of(h.transform), probes > 0);
        return;
    }
    hierarchy_ = build_hierarchy(h.mesh, {.levels = h.levels});
    layout_ = mesh_layout(*hierarchy_, h.mesh.width * h.mesh.height, probes);
    if (h.placement == MeshPlacement::centres) {
        // Sample (x, y) is pixel (x, y); past the last column or row it repeats the edge pixel.
        const std::vector<Vec2> p = refine_positions(*hierarchy_, h.mesh.vertices, h.levels);
        pixel_of_sample_.resize(p.size());
        for (size_t i = 0; i < p.size(); ++i) {
            const double x = std::round(p[i].x), y = std::round(p[i].y);
            if (std::abs(p[i].x - x) > 1e-6 || std::abs(p[i].y - y) > 1e-6) {
                throw Error(str("mesh sample ", i, " is not on a pixel centre"));
            }
            const int64_t px = std::min<int64_t>(static_cast<int64_t>(x), h.width - 1);
            const int64_t py = std::min<int64_t>(static_cast<int64_t>(y), h.height - 1);
            pixel_of_sample_[i] = static_cast<int32_t>(py * h.width + px);
            if (x < h.width && y < h.height) written_samples_.push_back(static_cast<int32_t>(i));
        }
    } else {
        plan_ = plan_render(*hierarchy_, h.mesh.vertices, h.mesh.width, h.mesh.height, h.width,
                            h.height);
    }
}

std::vector<std::vector<float>> StillDomain::samples(const Image& image) const {
    if (!hierarchy_) return image.planes;
    if (plan_) return sample_image(image, *hierarchy_, header_.mesh.vertices);
    std::vector<std::vector<float>> out(image.channels(), std::vector<float>(size()));
    for (int c = 0; c < image.channels(); ++c) {
        for (size_t i = 0; i < pixel_of_sample_.size(); ++i)
            out[c][i] = image.planes[c][pixel_of_sample_[i]];
    }
    return out;
}

Image StillDomain::to_image(const std::vector<std::vector<float>>& samples) const {
    const SampleFormat format = header_.bit_depth == 16 ? SampleFormat::u16 : SampleFormat::u8;
    if (!hierarchy_) {
        Image out = make_image(header_.width, header_.height, header_.channels, format);
        out.planes = samples;
        return out;
    }
    if (plan_) {
        std::vector<std::span<const float>> in(samples.begin(), samples.end());
        return render(*plan_, in, format);
    }
    Image out = make_image(header_.width, header_.height, header_.channels, format);
    for (int c = 0; c < out.channels(); ++c) {
        for (int32_t i : written_samples_) out.planes[c][pixel_of_sample_[i]] = samples[c][i];
    }
    return out;
}

std::vector<std::vector<float>> StillDomain::analyze(const Image& image) const {
    std::vector<std::vector<float>> x = samples(image);
    if (header_.colour == TwiColour::ycbcr) ycbcr_forward(x[0], x[1], x[2]);
    if (hierarchy_) {
        forward_transform(*hierarchy_, spans(x));
    } else {
        const GridTransformOptions o{.wavelet = wavelet_of(header_.transform),
                                     .levels = header_.levels};
        for (auto& plane : x) grid_forward(plane, header_.width, header_.height, o);
    }
    return x;
}

Image StillDomain::synthesize(std::vector<std::vector<float>> x) const {
    if (hierarchy_) {
        inverse_transform(*hierarchy_, spans(x));
    } else {
        const GridTransformOptions o{.wavelet = wavelet_of(header_.transform),
                                     .levels = header_.levels};
        for (auto& plane : x) grid_inverse(plane, header_.width, header_.height, o);
    }
    if (header_.colour == TwiColour::ycbcr) ycbcr_inverse(x[0], x[1], x[2]);
    return to_image(x);
}

std::vector<std::vector<int32_t>> StillDomain::samples_int(const Image& image) const {
    const std::vector<std::vector<float>> s = samples(image);
    const float top = max_value(header_);
    std::vector<std::vector<int32_t>> out(s.size(), std::vector<int32_t>(size()));
    for (size_t c = 0; c < s.size(); ++c) {
        for (int32_t i = 0; i < size(); ++i) {
            const float v = std::clamp(s[c][i], 0.0f, 1.0f) * top;
            out[c][i] = static_cast<int32_t>(std::lround(v));
        }
    }
    return out;
}

std::vector<std::vector<int32_t>> StillDomain::analyze_int(const Image& image) const {
    std::vector<std::vector<int32_t>> x = samples_int(image);
    if (header_.colour == TwiColour::ycocg_r) ycocg_r_forward(x[0], x[1], x[2]);
    if (hierarchy_) {
        forward_transform_int(*hierarchy_, spans(x));
    } else {
        for (auto& plane : x)
            grid_forward_int53(plane, header_.width, header_.height, header_.levels);
    }
    return x;
}

std::vector<std::vector<int32_t>> StillDomain::inverse_int(
    std::vector<std::vector<int32_t>> x) const {
    // The integer inverse grows values by less than 16x a level (at most 6.25x for the grid 5/3,
    // 10.75x for the mesh), so int32 is safe while largest * 16^levels < 2^30. Coefficients from
    // a damaged stream can exceed that: they take the int64 inverse, or are refused past 2^62.
    uint32_t largest = 0;
    for (const auto& plane : x) {
        for (int32_t v : plane)
            largest = std::max(largest, static_cast<uint32_t>(v < 0 ? -int64_t{v} : v));
    }
    const int levels = hierarchy_ ? hierarchy_->finest() : header_.levels;
    const int bits = std::bit_width(largest) + 4 * levels;
    if (bits <= 30) {
        if (hierarchy_) {
            inverse_transform_int(*hierarchy_, spans(x));
        } else {
            for (auto& plane : x)
                grid_inverse_int53(plane, header_.width, header_.height, header_.levels);
        }
    } else if (bits <= 62) {
        std::vector<std::vector<int64_t>> wide(x.size());
        for (size_t c = 0; c < x.size(); ++c) wide[c].assign(x[c].begin(), x[c].end());
        if (hierarchy_) {
            inverse_transform_int(*hierarchy_, spans(wide));
        } else {
            for (auto& plane : wide)
                grid_inverse_int53(plane, header_.width, header_.height, header_.levels);
        }
        constexpr int64_t kLimit = int64_t{1} << 30;  // no sample of a valid file comes near it
        for (size_t c = 0; c < x.size(); ++c) {
            for (size_t i = 0; i < x[c].size(); ++i) {
                x[c][i] = static_cast<int32_t>(std::clamp(wide[c][i], -kLimit, kLimit));
            }
        }
    } else {
        throw Error("lossless coefficients out of range (a corrupted stream)");
    }
    if (header_.colour == TwiColour::ycocg_r) ycocg_r_inverse(x[0], x[1], x[2]);
    return x;
}

Image StillDomain::synthesize_int(std::vector<std::vector<int32_t>> coefficients) const {
    const std::vector<std::vector<int32_t>> x = inverse_int(std::move(coefficients));
    const float scale = 1.0f / max_value(header_);
    std::vector<std::vector<float>> s(x.size(), std::vector<float>(size()));
    for (size_t c = 0; c < x.size(); ++c) {
        for (int32_t i = 0; i < size(); ++i) s[c][i] = static_cast<float>(x[c][i]) * scale;
    }
    return to_image(s);
}

}  // namespace tesswave
