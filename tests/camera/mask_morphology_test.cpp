#include "camera/mask_morphology.h"
#include "core/error.h"

#include <doctest/doctest.h>

using namespace sdfkit;

TEST_CASE("dilate_mask: the pixels within the disc of a mask pixel, closed forms at the border and inside") {
  Image one(9, 9, 1, 0.0f);
  one.at(4, 4) = 0.8f;
  one.at(0, 0) = 0.5f;  // not over 0.5: not a mask pixel
  const auto count = [](const Image& m) {
    long n = 0;
    for (const float v : m.data) n += v == 1.0f;
    return n;
  };
  CHECK(count(dilate_mask(one, 0)) == 1);
  CHECK(count(dilate_mask(one, 1)) == 5);   // the cross
  CHECK(count(dilate_mask(one, 2)) == 13);  // dx^2 + dy^2 <= 4
  const Image d2 = dilate_mask(one, 2);
  CHECK(d2.at(6, 4) == 1.0f);
  CHECK(d2.at(5, 6) == 0.0f);  // 1 + 4 > 4
  // A corner pixel keeps only the disc's part inside the image.
  Image corner(9, 9, 1, 0.0f);
  corner.at(0, 0) = 1.0f;
  CHECK(count(dilate_mask(corner, 2)) == 6);  // (0..2, 0), (0..1, 1), (0, 2)
  CHECK_THROWS_AS(dilate_mask(Image(4, 4, 3, 0.0f), 1), InvalidInput);
  CHECK_THROWS_AS(dilate_mask(one, -1), InvalidInput);
}
