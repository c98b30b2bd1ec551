// Connected components of a triangle mesh (faces sharing a vertex are connected): used by the extraction's
// clean-up (extract/cleanup.h) and by the sign method's one-part test (sdf/pseudonormal.h).
#pragma once

#include "core/types.h"

#include <vector>

namespace sdfkit {

/// Component id of every face (faces sharing a vertex are connected); ids are numbered in order of each
/// component's first face. `count` receives the number of components. Throws InvalidInput on an out-of-range
/// vertex index.
std::vector<int> face_components(const Mesh& mesh, int* count = nullptr);

}  // namespace sdfkit
