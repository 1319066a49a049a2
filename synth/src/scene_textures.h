// Procedural textures for the synthetic scenes (internal to the synthetic sequence writer); all
// colours are BGR and every texture is drawn from `rng`, so a seed gives the same scene.
#pragma once

#include <opencv2/core.hpp>

namespace stillmap::synth {

// Smooth value noise around `base` (`cells` x `cells` knots over `size` pixels) plus fine grain.
cv::Mat NoiseTexture(cv::RNG& rng, const cv::Scalar& base, double amplitude, int size, int cells,
                     double grain);
cv::Scalar RandomColor(cv::RNG& rng, int lo, int hi);
// A painted wall with posters, frames and notes: high-contrast corners and edges.
cv::Mat WallTexture(cv::RNG& rng, const cv::Scalar& paint);
cv::Mat WoodTexture(cv::RNG& rng, const cv::Scalar& tone);
cv::Mat StripeTexture(cv::RNG& rng, const cv::Scalar& a, const cv::Scalar& b);
cv::Mat ScreenTexture(cv::RNG& rng);
// A face on skin, for a head's texture (u around from the front, v from the top).
cv::Mat FaceTexture(cv::RNG& rng, const cv::Scalar& skin, const cv::Scalar& hair);

// Floor tiles, `tiles` x `tiles` over a `size` px texture: each tile its own shade of `base`,
// speckled, grout between them and scuffs, so that no two stretches of a corridor look the same.
cv::Mat TileTexture(cv::RNG& rng, const cv::Scalar& base, int tiles, int size);
// Paint and nothing else: a blank corridor wall.
cv::Mat PlainPaint(cv::RNG& rng, const cv::Scalar& paint);
// A whiteboard with marker lines, boxes and words.
cv::Mat WhiteboardTexture(cv::RNG& rng);

}  // namespace stillmap::synth
