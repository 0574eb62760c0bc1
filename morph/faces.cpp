#include "faces.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "core/math/error.h"
#include "core/math/strings.h"

#ifdef TESSWAVE_HAVE_DLIB
#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>
#include <dlib/image_transforms.h>

#include <future>
#include <memory>
#include <mutex>
#endif

namespace tesswave::morph {
namespace {

std::string model_path() {
    const char* env = std::getenv("TESSWAVE_FACE_MODEL");
    return env && *env ? env : kFaceModel;
}

// Points above the brows, along the face's up direction (chin to the middle of the brows): the
// forehead is about half as tall as chin-to-brows, less at the temples.
std::vector<Vec2> forehead(const std::vector<Vec2>& landmarks) {
    const Vec2 brows = 0.5 * (landmarks[21] + landmarks[22]);
    const Vec2 up = brows - landmarks[8];
    std::vector<Vec2> out;
    const int brow[kForeheadPoints] = {17, 19, 21, 24, 26};
    const double rise[kForeheadPoints] = {0.25, 0.4, 0.45, 0.4, 0.25};
    for (int k = 0; k < kForeheadPoints; ++k) {
        out.push_back(k == 2 ? brows + rise[k] * up : landmarks[brow[k]] + rise[k] * up);
    }
    return out;
}

}  // namespace

#ifdef TESSWAVE_HAVE_DLIB

namespace {

struct Models {
    dlib::frontal_face_detector detector = dlib::get_frontal_face_detector();
    std::mutex mutex;  // the detector keeps scratch buffers
};

Models& models() {
    static Models m;
    return m;
}

// The landmark model (about 100 MB, half a second to read) loads on a worker thread from the
// first prepare_faces() or find_face(), so that it overlaps reading the images and detecting the
// faces. A failed load is reported by find_face and retried by the next call.
struct Predictor {
    std::mutex mutex;
    std::shared_future<std::shared_ptr<const dlib::shape_predictor>> loading;
};

Predictor& predictor_state() {
    static Predictor p;
    return p;
}

std::shared_future<std::shared_ptr<const dlib::shape_predictor>> start_loading() {
    Predictor& p = predictor_state();
    std::lock_guard<std::mutex> lock(p.mutex);
    if (!p.loading.valid()) {
        p.loading = std::async(std::launch::async, [] {
                        auto model = std::make_shared<dlib::shape_predictor>();
                        const std::string path = model_path();
                        try {
                            dlib::deserialize(path) >> *model;
                        } catch (const std::exception& e) {
                            throw Error(str(path, ": not a dlib shape predictor (", e.what(), ")"));
                        }
                        return std::shared_ptr<const dlib::shape_predictor>(std::move(model));
                    }).share();
    }
    return p.loading;
}

const dlib::shape_predictor& loaded_predictor() {
    auto loading = start_loading();
    try {
        return *loading.get();
    } catch (...) {
        Predictor& p = predictor_state();
        std::lock_guard<std::mutex> lock(p.mutex);
        p.loading = {};  // the next call tries again
        throw;
    }
}

}  // namespace

bool faces_available() { return faces_missing().empty(); }

std::string faces_missing() {
    const std::string path = model_path();
    if (!std::filesystem::is_regular_file(path)) {
        return str("the face landmark model ", path,
                   " is missing (Debian package libdlib-data, or set TESSWAVE_FACE_MODEL)");
    }
    return {};
}

void prepare_faces() {
    if (faces_available()) start_loading();
}

std::optional<Face> find_face(const Image& image) {
    if (const std::string missing = faces_missing(); !missing.empty()) throw Error(missing);
    start_loading();
    if (image.width < 16 || image.height < 16) return std::nullopt;
    Models& m = models();
    dlib::array2d<unsigned char> grey(image.height, image.width);
    const bool rgb = image.channels() >= 3;
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            const float v = rgb ? 0.299f * image.at(0, x, y) + 0.587f * image.at(1, x, y) +
                                      0.114f * image.at(2, x, y)
                                : image.at(0, x, y);
            grey[y][x] = static_cast<unsigned char>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255));
        }
    }
    // Detection on a copy at most 1024 pixels a side (the detector's cost grows with the area;
    // faces that small in a large photo are not what a morph is after), upsampled once when
    // nothing is found, as dlib's examples do for faces under 80 pixels.
    const double shrink = std::min(1.0, 1024.0 / std::max(image.width, image.height));
    dlib::array2d<unsigned char> small;
    const dlib::array2d<unsigned char>* detect_on = &grey;
    if (shrink < 1) {
        small.set_size(std::lround(image.height * shrink), std::lround(image.width * shrink));
        dlib::resize_image(grey, small);
        detect_on = &small;
    }
    std::vector<dlib::rectangle> faces;
    double scale = shrink;
    {
        std::lock_guard<std::mutex> lock(m.mutex);
        faces = m.detector(*detect_on);
        if (faces.empty() && shrink == 1 && image.width * image.height <= 1 << 21) {
            dlib::array2d<unsigned char> up;
            dlib::pyramid_up(*detect_on, up, dlib::pyramid_down<2>());
            faces = m.detector(up);
            scale = 2;
        }
    }
    if (faces.empty()) return std::nullopt;
    const auto largest = std::max_element(faces.begin(), faces.end(),
                                          [](auto& p, auto& q) { return p.area() < q.area(); });
    const dlib::rectangle box(
        std::lround(largest->left() / scale), std::lround(largest->top() / scale),
        std::lround(largest->right() / scale), std::lround(largest->bottom() / scale));
    const dlib::full_object_detection shape = loaded_predictor()(grey, box);
    Face face;
    face.found = static_cast<int>(faces.size());
    face.left = box.left();
    face.top = box.top();
    face.width = box.width();
    face.height = box.height();
    for (unsigned k = 0; k < shape.num_parts(); ++k) {
        // dlib gives pixel indices; our points are at pixel centres.
        face.points.push_back({shape.part(k).x() + 0.5, shape.part(k).y() + 0.5});
    }
    if (face.points.size() != kFaceLandmarks) {
        throw Error(
            str(model_path(), ": the model gives ", face.points.size(), " landmarks, not 68"));
    }
    const std::vector<Vec2> top = forehead(face.points);
    face.points.insert(face.points.end(), top.begin(), top.end());
    return face;
}

#else

bool faces_available() { return false; }

std::string faces_missing() {
    return "this build has no face landmarks (dlib was not found: Debian packages libdlib-dev "
           "and libdlib-data)";
}

void prepare_faces() {}

std::optional<Face> find_face(const Image&) { throw Error(faces_missing()); }

#endif

}  // namespace tesswave::morph
