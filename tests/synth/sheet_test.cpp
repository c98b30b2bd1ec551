#include "synth/sheet.h"

#include "core/error.h"

#include <doctest/doctest.h>

using namespace sdfkit;

namespace {
bool white(const Image& im, int x, int y) {
  return im.at(x, y, 0) > 0.99f && im.at(x, y, 1) > 0.99f && im.at(x, y, 2) > 0.99f;
}
}  // namespace

TEST_CASE("contact sheet: one labelled row per category, every shape visible inside its cell") {
  SynthSettings s;
  s.per_category = 5;
  s.seed = 9;
  s.categories = {"chair", "rifle"};
  SheetSettings sh;
  sh.per_category = 2;  // fewer than the benchmark has: the first 2 of each category
  sh.cell = 48;
  sh.label_width = 60;
  sh.supersampling = 1;
  const Image im = contact_sheet(s, sh);
  REQUIRE(im.channels == 3);
  CHECK(im.width == 60 + 2 * 48);
  CHECK(im.height == 2 * 48);
  for (int row = 0; row < 2; ++row)
    for (int col = 0; col < 2; ++col) {
      const int x0 = 60 + col * 48, y0 = row * 48;
      int covered = 0;
      bool border_white = true;
      for (int y = 1; y < 48; ++y)
        for (int x = 0; x < 48; ++x) {
          covered += !white(im, x0 + x, y0 + y);
          // The unit sphere seen from distance 2.5 fits in the field of view: the cell border stays empty.
          if (x == 0 || x == 47 || y == 47) border_white = border_white && white(im, x0 + x, y0 + y);
        }
      CAPTURE(row);
      CAPTURE(col);
      CHECK(covered > 20);
      CHECK(border_white);
    }
  // The label column holds text.
  int ink = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < 60; ++x) ink += im.at(x, y, 0) < 0.5f;
  CHECK(ink > 10);
  // Deterministic.
  const Image again = contact_sheet(s, sh);
  CHECK(again.data == im.data);
  // A split base larger than the sheet's shapes per category changes nothing on the sheet (it shows shapes).
  s.split_base = 4;
  CHECK(contact_sheet(s, sh).data == im.data);
  sh.cell = 4;
  CHECK_THROWS_AS(contact_sheet(s, sh), sdfkit::InvalidInput);
}
