// Texture images for mesh colours: the TextureSampler that read_mesh (core/mesh_io.h) uses to colour textured OBJ
// and glTF parts, reading the image through camera/image.h.
#pragma once

#include "camera/image.h"
#include "core/mesh_io.h"

#include <Eigen/Core>

namespace sdfkit {

/// Bilinear RGB of `image` at texture coordinates (u, v): u = 0..1 left to right, v = 0..1 bottom to top (OBJ and
/// glTF both address textures so after assimp's import), wrapping outside [0, 1). Grey images give grey, alpha is
/// ignored.
Eigen::Vector3f sample_texture(const Image& image, const Eigen::Vector2f& uv);

/// A TextureSampler reading each texture file once (cached by path for the sampler's lifetime). Thread-safe.
TextureSampler image_texture_sampler();

}  // namespace sdfkit
