// Automatic face landmarks (dlib): the largest frontal face in an image and its 68 landmarks
// (the iBUG 300-W layout of dlib's shape_predictor_68_face_landmarks.dat, Debian package
// libdlib-data), plus forehead points above the brows, for landmark morphs without point files.
// An optional part of the build: without dlib, faces_available() is false and find_face throws.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/image.h"

namespace tesswave::morph {

// The model file the build looks for first (overridden by $TESSWAVE_FACE_MODEL).
inline constexpr const char* kFaceModel = "/usr/share/dlib/shape_predictor_68_face_landmarks.dat";

// True when this build has dlib and its landmark model is on the machine.
bool faces_available();

// Why faces_available() is false ("" when it is true): names what is missing.
std::string faces_missing();

struct Face {
    // The 68 landmarks then kForeheadPoints points above the brows, in the image's pixels
    // (pixel-centre convention of DESIGN.md 2.1). Those of a face cut by the image's edge lie
    // outside it, where the predictor puts them.
    std::vector<Vec2> points;
    int found = 0;  // frontal faces detected; points are of the largest
    double left = 0, top = 0, width = 0, height = 0;  // its detection box
};

inline constexpr int kFaceLandmarks = 68;
inline constexpr int kForeheadPoints = 5;

// Starts reading the landmark model on a worker thread, so that it overlaps reading the images
// and detecting the faces (find_face starts it too, and waits for it only to place the
// landmarks). Does nothing when faces are not available; a load that fails is reported by
// find_face.
void prepare_faces();

// The largest frontal face of the image, or nothing when no face is found (images too small for
// the detector, about 40 pixels a face side after one upsampling, find none). Throws Error when
// faces are not available (faces_missing() says why) or the model cannot be read.
std::optional<Face> find_face(const Image& image);

}  // namespace tesswave::morph
