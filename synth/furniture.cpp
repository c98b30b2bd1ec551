// Furniture families: chair, table, bench, sofa, cabinet. +y up, floor at y = 0, front towards +z, width along x.
#include "synth/generators.h"

#include <cmath>

namespace sdfkit {
namespace {

/// A leg from floor point `foot` up to `top`, in one of several styles (0 square bar, 1 cylinder, 2 tapered).
void add_leg(Gen& g, const std::string& name, int style, const Vec3& foot, const Vec3& top, double size,
             const Vec3f& color) {
  if (style == 0)
    g.add(name, make_bar(foot, top, size, size, Vec3::UnitZ()), color);
  else if (style == 1)
    g.add(name, make_cylinder(foot, top, 0.5 * size, 12), color);
  else
    g.add(name, make_cone(foot, top, 0.28 * size, 0.5 * size, 12), color);
}

struct LegLine {
  Vec3 foot, top;
};

/// Four legs under a rectangle of half sizes (hx, hz) reaching from the floor to height `top_y`; `splay` moves
/// the feet outwards. Order: (-x,-z), (-x,+z), (+x,-z), (+x,+z).
std::array<LegLine, 4> add_four_legs(Gen& g, int style, double hx, double hz, double top_y, double size, double splay,
                                     const Vec3f& color) {
  std::array<LegLine, 4> legs;
  int k = 0;
  for (const double sx : {-1.0, 1.0})
    for (const double sz : {-1.0, 1.0}) {
      const Vec3 top(sx * hx, top_y, sz * hz);
      const Vec3 foot(sx * (hx + splay), 0.0, sz * (hz + splay));
      add_leg(g, "leg", style, foot, top, size, color);
      legs[k++] = {foot, top};
    }
  return legs;
}

/// Point at height y on a leg.
Vec3 along_leg(const LegLine& l, double y) {
  const double t = (y - l.foot.y()) / (l.top.y() - l.foot.y());
  return l.foot + t * (l.top - l.foot);
}

/// Stretchers between the legs at height y: an H (two side bars and a middle cross bar) or a ring of four.
void add_stretchers(Gen& g, const std::array<LegLine, 4>& legs, double y, double size, bool h_pattern,
                    const Vec3f& color) {
  auto bar = [&](const Vec3& a, const Vec3& b) {
    g.add("stretcher", make_bar(a, b, size, size, Vec3::UnitY()), color);
  };
  auto pt = [&](int i) { return along_leg(legs[i], y); };
  bar(pt(0), pt(1));
  bar(pt(2), pt(3));
  if (h_pattern) {
    bar(0.5 * (pt(0) + pt(1)), 0.5 * (pt(2) + pt(3)));
  } else {
    bar(pt(0), pt(2));
    bar(pt(1), pt(3));
  }
}

}  // namespace

// ------------------------------------------------------------------------------------------------ chair
SynthShape make_chair(Gen& g) {
  const double W = g.u(0.38, 0.62), D = g.u(0.38, 0.56), H = g.u(0.38, 0.52), T = g.u(0.025, 0.08);
  const Vec3f frame_c = g.p(0.6) ? g.pick(palette::kWood) : g.pick(palette::kMetal);
  const Vec3f seat_c = g.p(0.5) ? frame_c : g.pick(palette::kFabric);
  const Vec3f back_c = g.p(0.7) ? seat_c : g.pick(palette::kFabric);
  // Seat.
  if (g.p(0.5))
    g.add("seat", make_rounded_box(Vec3(0, H - T / 2, 0), Vec3(W / 2, T / 2, D / 2), g.u(0.005, T / 2)), seat_c);
  else
    g.add("seat", make_box_part(Vec3(0, H - T / 2, 0), Vec3(W / 2, T / 2, D / 2)), seat_c);

  // Base.
  const int base = g.choose({0.62, 0.2, 0.18});  // four legs, office pedestal, sled frame
  const double post = g.u(0.022, 0.05);           // leg / back post size
  const double inset = g.u(0.0, 0.04);
  const double hx = W / 2 - inset - post / 2, hz = D / 2 - inset - post / 2;
  bool back_posts_from_legs = false;
  if (base == 0) {
    const int style = g.n(0, 2);
    const double splay = g.p(0.4) ? g.u(0.0, 0.05) : 0.0;
    const auto feet = add_four_legs(g, style, hx, hz, H - T * 0.3, post, splay, frame_c);
    if (g.p(0.5)) {
      const double y = g.u(0.08, 0.25);
      const double size = g.u(0.012, 0.022);
      const bool h = g.p(0.5);
      add_stretchers(g, feet, y, size, h, frame_c);
    }
    back_posts_from_legs = style == 0 && g.p(0.5);
  } else if (base == 1) {
    const Vec3f dark = g.pick(palette::kDark);
    const double col_r = g.u(0.02, 0.035), foot_y = g.u(0.05, 0.08);
    g.add("column", make_cylinder(Vec3(0, foot_y, 0), Vec3(0, H - T * 0.5, 0), col_r, 14), frame_c);
    const double mx = g.u(0.06, 0.12), mz = g.u(0.06, 0.12);
    g.add("mechanism", make_box_part(Vec3(0, H - T - 0.02, 0), Vec3(mx, 0.025, mz)), dark);
    const int arms = g.n(4, 5);
    const double reach = g.u(0.24, 0.34), phase = g.u(0, 2 * M_PI);
    for (int a = 0; a < arms; ++a) {
      const double ang = phase + 2 * M_PI * a / arms;
      const Vec3 dir(std::cos(ang), 0, std::sin(ang));
      const Vec3 end = Vec3(0, foot_y, 0) + reach * dir;
      g.add("star_arm", make_bar(Vec3(0, foot_y, 0), end, 0.035, 0.03, Vec3::UnitY()), dark);
      g.add("caster", make_ellipsoid(end + Vec3(0, -foot_y / 2, 0), Vec3(0.025, foot_y / 2, 0.025), Mat3::Identity(), 3),
            dark);
    }
  } else {
    const double r = g.u(0.009, 0.016);
    for (const double sx : {-1.0, 1.0}) {
      const double x = sx * (W / 2 - inset);
      const std::vector<Vec3> path = {Vec3(x, H - T, D / 2 - 0.05), Vec3(x, H - T - 0.02, D / 2),
                                      Vec3(x, r, D / 2 + 0.02),     Vec3(x, r, -D / 2),
                                      Vec3(x, H - T, -D / 2 + 0.04)};
      g.add("sled_frame", make_tube(path, {r}, 10), frame_c);
    }
    g.add("sled_cross", make_cylinder(Vec3(-(W / 2 - inset), r, -D / 2 + 0.02), Vec3(W / 2 - inset, r, -D / 2 + 0.02),
                                      r, 10),
          frame_c);
  }

  // Back, built in a local frame (x across, y up the back, z forward) then tilted back around the seat's rear edge.
  const double Hb = g.u(0.3, 0.62), tilt = g.u(0.0, 0.28), tb = g.u(0.018, 0.03);
  const Mat3 R = rot_x(-tilt);
  const Vec3 origin(0, H, -D / 2 + post / 2 + inset * 0.5);
  auto place = [&](const Mesh& m) { return transformed(m, R, origin); };
  const int style = g.choose({0.22, 0.22, 0.18, 0.2, 0.18});  // panel, vertical slats, rails, frame+hole, spindles
  const double bw = W / 2 - inset;  // half width of the back
  if (style == 0) {
    const double th = g.u(0.03, 0.07);
    g.add("back_panel", place(make_rounded_box(Vec3(0, Hb / 2, 0), Vec3(bw, Hb / 2, th / 2), g.u(0.005, th / 2))),
          back_c);
    if (back_posts_from_legs) {
      for (const double sx : {-1.0, 1.0})
        g.add("back_post", place(make_bar(Vec3(sx * hx, -0.02, -th / 2 - post / 2), Vec3(sx * hx, Hb * 0.8, -th / 2 - post / 2),
                                          post, post, Vec3::UnitZ())),
              frame_c);
    }
  } else {
    // Frame: two posts and a top rail.
    const double rail_h = g.u(0.035, 0.09);
    for (const double sx : {-1.0, 1.0})
      g.add("back_post", place(make_bar(Vec3(sx * (bw - post / 2), -T * 0.5, 0), Vec3(sx * (bw - post / 2), Hb, 0), post,
                                        std::max(post * 0.8, tb), Vec3::UnitZ())),
            frame_c);
    g.add("top_rail", place(make_box_part(Vec3(0, Hb - rail_h / 2, 0), Vec3(bw, rail_h / 2, std::max(tb, post * 0.4)))),
          back_c);
    const double low = g.u(0.04, 0.12);  // bottom of the open area
    const bool bottom_rail = style == 3 || g.p(0.6);
    const double bottom_h = g.u(0.03, 0.07);
    if (bottom_rail)
      g.add("bottom_rail",
            place(make_box_part(Vec3(0, low + bottom_h / 2, 0), Vec3(bw - post / 2, bottom_h / 2, tb * 0.6))), frame_c);
    const double y0 = bottom_rail ? low + bottom_h * 0.5 : -T * 0.5, y1 = Hb - rail_h * 0.5;
    const double inner = bw - post;  // half width of the opening
    if (style == 1) {
      const int n = g.n(2, 7);
      const double sw = g.u(0.018, 0.05);
      const double depth = g.u(0.012, 0.025);
      for (int i = 0; i < n; ++i) {
        const double x = -inner + 2 * inner * (i + 1) / (n + 1);
        g.add("back_slat", place(make_box_part(Vec3(x, 0.5 * (y0 + y1), 0), Vec3(sw / 2, 0.5 * (y1 - y0), depth / 2))),
              back_c);
      }
    } else if (style == 2) {
      const int n = g.n(2, 5);
      const double sh = g.u(0.02, 0.06), depth = g.u(0.012, 0.025);
      for (int i = 0; i < n; ++i) {
        const double y = y0 + (y1 - y0) * (i + 0.5) / (n + 0.3);
        g.add("back_slat", place(make_box_part(Vec3(0, y, 0), Vec3(inner + post * 0.4, sh / 2, depth / 2))), back_c);
      }
    } else if (style == 3) {
      // Frame around a hole; sometimes a central splat board.
      if (g.p(0.4)) {
        const double sw = g.u(0.06, 0.14);
        g.add("splat", place(make_box_part(Vec3(0, 0.5 * (y0 + y1), 0), Vec3(sw / 2, 0.5 * (y1 - y0), 0.008))), back_c);
      }
    } else {
      const int n = g.n(3, 9);
      const double r = g.u(0.006, 0.012);
      for (int i = 0; i < n; ++i) {
        const double x = -inner + 2 * inner * (i + 1) / (n + 1);
        g.add("back_slat", place(make_cylinder(Vec3(x, y0, 0), Vec3(x, y1, 0), r, 8)), frame_c);
      }
    }
  }

  // Arm rests.
  if (g.p(0.35)) {
    const double ah = g.u(0.17, 0.27), aw = g.u(0.025, 0.06);
    const bool solid = g.p(0.3);
    for (const double sx : {-1.0, 1.0}) {
      const double x = sx * (W / 2 - aw / 2);
      const double zf = D / 2 - g.u(0.0, 0.08);
      if (solid) {
        g.add("arm_panel", make_box_part(Vec3(x, H + ah / 2, -0.02), Vec3(aw / 2, ah / 2, D / 2 - 0.03)), seat_c);
      } else {
        g.add("arm_post", make_bar(Vec3(x, H - T / 2, zf - 0.02), Vec3(x, H + ah, zf - 0.02), aw * 0.7, aw * 0.7,
                                   Vec3::UnitZ()),
              frame_c);
        g.add("arm_rail", make_bar(Vec3(x, H + ah, zf + 0.02), Vec3(x, H + ah, -D / 2 + 0.02), aw, 0.025, Vec3::UnitY()),
              frame_c);
      }
    }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ table
SynthShape make_table(Gen& g) {
  const int kind = g.choose({0.5, 0.25, 0.25});  // dining, coffee, desk/bar
  double L = g.u(0.9, 1.9), Dp = g.u(0.6, 1.0), H = g.u(0.68, 0.78);
  if (kind == 1) {
    L = g.u(0.6, 1.3);
    Dp = g.u(0.4, 0.8);
    H = g.u(0.32, 0.48);
  } else if (kind == 2) {
    L = g.u(0.8, 1.6);
    Dp = g.u(0.5, 0.8);
    H = g.p(0.7) ? g.u(0.7, 0.78) : g.u(0.95, 1.08);
  }
  const double T = g.u(0.02, 0.06);
  const bool round = g.p(0.25);
  if (round) L = Dp = g.u(0.6, 1.2);
  const Vec3f top_c = g.p(0.7) ? g.pick(palette::kWood) : g.pick(palette::kPlastic);
  const Vec3f leg_c = g.p(0.6) ? top_c : g.pick(palette::kMetal);
  if (round)
    g.add("top", make_cylinder(Vec3(0, H - T, 0), Vec3(0, H, 0), L / 2, 32), top_c);
  else if (g.p(0.5))
    g.add("top", make_rounded_box(Vec3(0, H - T / 2, 0), Vec3(L / 2, T / 2, Dp / 2), g.u(0.004, T / 2)), top_c);
  else
    g.add("top", make_box_part(Vec3(0, H - T / 2, 0), Vec3(L / 2, T / 2, Dp / 2)), top_c);

  const int base = g.choose({0.55, 0.2, 0.12, 0.13});  // legs, pedestal, trestle, panel sides
  const double leg = g.u(0.025, 0.07);
  if (base == 0) {
    const double overhang = g.u(0.0, 0.12);
    double hx = L / 2 - overhang - leg / 2, hz = Dp / 2 - overhang - leg / 2;
    if (round) hx = hz = 0.7 * (L / 2 - leg) / std::sqrt(2.0);
    hx = std::max(hx, 0.1);
    hz = std::max(hz, 0.1);
    const int style = g.n(0, 2);
    const double splay = g.p(0.25) ? g.u(0.0, 0.06) : 0.0;
    const auto feet = add_four_legs(g, style, hx, hz, H - T * 0.5, leg, splay, leg_c);
    if (!round && g.p(0.6)) {  // apron frame under the top
      const double ah = g.u(0.05, 0.12), at = g.u(0.015, 0.025);
      const double y = H - T - ah / 2 + 0.002;
      for (const double sz : {-1.0, 1.0})
        g.add("apron", make_box_part(Vec3(0, y, sz * hz), Vec3(hx, ah / 2, at / 2)), leg_c);
      for (const double sx : {-1.0, 1.0})
        g.add("apron", make_box_part(Vec3(sx * hx, y, 0), Vec3(at / 2, ah / 2, hz)), leg_c);
      if (g.p(0.3))
        g.add("drawer_knob", make_ellipsoid(Vec3(0, y, hz + at / 2 + 0.01), Vec3(0.015, 0.015, 0.012), Mat3::Identity(), 3),
              g.pick(palette::kMetal));
    }
    if (g.p(0.35)) {
      const double y = g.u(0.08, 0.25);
      const double size = g.u(0.015, 0.03);
      const bool h = g.p(0.5);
      add_stretchers(g, feet, y, size, h, leg_c);
    }
    if (!round && g.p(0.2)) {
      const double sy = g.u(0.08, 0.2);
      g.add("shelf", make_box_part(Vec3(0, sy, 0), Vec3(hx + splay * 0.5, 0.01, hz + splay * 0.5)), top_c);
    }
  } else if (base == 1) {
    const double col = g.u(0.03, 0.09);
    const int n = round ? 1 : (L > 1.3 ? 2 : 1);
    for (int i = 0; i < n; ++i) {
      const double x = n == 1 ? 0.0 : (i == 0 ? -1 : 1) * L * 0.28;
      g.add("column", make_cylinder(Vec3(x, 0.02, 0), Vec3(x, H - T * 0.5, 0), col, 16), leg_c);
      if (g.p(0.5)) {
        const double bh = g.u(0.02, 0.05), br = g.u(0.18, std::min(0.35, Dp * 0.45));
        g.add("base", make_cylinder(Vec3(x, 0, 0), Vec3(x, bh, 0), br, 24), leg_c);
      } else {
        const int feet = g.n(3, 4);
        const double reach = g.u(0.2, std::min(0.4, Dp * 0.5));
        for (int f = 0; f < feet; ++f) {
          const double a = 2 * M_PI * f / feet + M_PI / 4;
          g.add("foot", make_bar(Vec3(x, 0.025, 0), Vec3(x + reach * std::cos(a), 0.02, reach * std::sin(a)), 0.045, 0.04,
                                 Vec3::UnitY()),
                leg_c);
        }
      }
    }
  } else if (base == 2) {
    const double x = L / 2 - g.u(0.08, 0.2), w = g.u(0.03, 0.06);
    for (const double sx : {-1.0, 1.0}) {
      const double xx = sx * x;
      g.add("trestle_foot", make_box_part(Vec3(xx, 0.03, 0), Vec3(w, 0.03, Dp / 2 - 0.05)), leg_c);
      g.add("trestle_post", make_box_part(Vec3(xx, H / 2, 0), Vec3(w * 0.7, H / 2 - 0.01, g.u(0.03, 0.08))), leg_c);
      g.add("trestle_cap", make_box_part(Vec3(xx, H - T - 0.02, 0), Vec3(w, 0.02, Dp / 2 - 0.08)), leg_c);
    }
    g.add("trestle_beam", make_bar(Vec3(-x, H * 0.35, 0), Vec3(x, H * 0.35, 0), 0.03, 0.06, Vec3::UnitY()), leg_c);
  } else {
    const double t = g.u(0.02, 0.04);
    for (const double sx : {-1.0, 1.0})
      g.add("side_panel", make_box_part(Vec3(sx * (L / 2 - t / 2 - 0.01), (H - T) / 2 + 0.002, 0),
                                        Vec3(t / 2, (H - T) / 2, Dp / 2 - 0.01)),
            leg_c);
    if (g.p(0.6))
      g.add("modesty_panel", make_box_part(Vec3(0, H * 0.6, -Dp / 2 + 0.05), Vec3(L / 2 - t, H * 0.25, 0.01)), leg_c);
    if (g.p(0.5)) {  // drawer unit with handles
      const double dw = g.u(0.3, 0.45), x = L / 2 - t - dw / 2;
      const double dh = H - T - 0.02;
      g.add("drawer_unit", make_box_part(Vec3(x, dh / 2 + 0.01, 0), Vec3(dw / 2, dh / 2, Dp / 2 - 0.04)), top_c);
      const int nd = g.n(2, 4);
      for (int i = 0; i < nd; ++i) {
        const double y = 0.01 + dh * (i + 0.5) / nd;
        g.add("handle", make_bar(Vec3(x - dw * 0.2, y, Dp / 2 - 0.02), Vec3(x + dw * 0.2, y, Dp / 2 - 0.02), 0.012, 0.02,
                                 Vec3::UnitY()),
              g.pick(palette::kMetal));
      }
    }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ bench
SynthShape make_bench(Gen& g) {
  const double L = g.u(0.9, 2.0), D = g.u(0.3, 0.5), H = g.u(0.38, 0.5);
  const Vec3f wood = g.pick(palette::kWood);
  const Vec3f frame = g.p(0.5) ? g.pick(palette::kMetal) : g.pick(palette::kDark);
  const bool slatted = g.p(0.8);
  const double st = g.u(0.02, 0.045);  // seat board thickness
  if (slatted) {
    const int n = g.n(3, 7);
    const double gap = g.u(0.008, 0.03);
    const double sw = (D - gap * (n - 1)) / n;
    for (int i = 0; i < n; ++i) {
      const double z = -D / 2 + sw / 2 + i * (sw + gap);
      g.add("seat_slat", make_box_part(Vec3(0, H - st / 2, z), Vec3(L / 2, st / 2, sw / 2)), wood);
    }
  } else {
    g.add("seat", make_box_part(Vec3(0, H - st / 2, 0), Vec3(L / 2, st / 2, D / 2)), wood);
  }
  // Supports: several pairs of legs joined by cross bars, or solid end panels, or curved cast sides.
  const int style = g.choose({0.45, 0.3, 0.25});
  const int pairs = L > 1.5 ? 3 : 2;
  const double ex = L / 2 - g.u(0.05, 0.18);
  const double leg = g.u(0.03, 0.06);
  const Vec3f sc = style == 1 ? wood : frame;
  for (int p = 0; p < pairs; ++p) {
    const double x = -ex + 2 * ex * p / (pairs - 1);
    if (style == 0) {
      for (const double sz : {-1.0, 1.0})
        g.add("leg", make_bar(Vec3(x, 0, sz * (D / 2 - leg)), Vec3(x, H - st * 0.5, sz * (D / 2 - leg)), leg, leg,
                              Vec3::UnitZ()),
              sc);
      g.add("cross_bar", make_bar(Vec3(x, H - st - 0.02, -D / 2 + 0.01), Vec3(x, H - st - 0.02, D / 2 - 0.01), leg,
                                  0.04, Vec3::UnitY()),
            sc);
      if (g.p(0.6))
        g.add("cross_bar", make_bar(Vec3(x, H * 0.25, -D / 2 + leg), Vec3(x, H * 0.25, D / 2 - leg), leg * 0.6,
                                    leg * 0.6, Vec3::UnitY()),
              sc);
    } else if (style == 1) {
      if (p == 0 || p == pairs - 1)
        g.add("end_panel", make_box_part(Vec3(x, (H - st) / 2 + 0.003, 0), Vec3(0.02, (H - st) / 2, D / 2 - 0.02)), sc);
    } else {
      const double r = g.u(0.01, 0.018);
      for (const double sz : {-1.0, 1.0}) {
        const auto path = bezier(Vec3(x, H - st, sz * 0.05), Vec3(x, H * 0.6, sz * D * 0.5),
                                 Vec3(x, H * 0.2, sz * D * 0.3), Vec3(x, r, sz * (D / 2 + 0.02)), 8);
        g.add("cast_leg", make_tube(path, {r}, 8), sc);
      }
      g.add("cross_bar", make_bar(Vec3(x, H - st - 0.012, -D / 2 + 0.02), Vec3(x, H - st - 0.012, D / 2 - 0.02), 0.03,
                                  0.024, Vec3::UnitY()),
            sc);
    }
  }
  if (style != 1 && g.p(0.5))
    g.add("stretcher", make_bar(Vec3(-ex, H * 0.3, 0), Vec3(ex, H * 0.3, 0), 0.025, 0.025, Vec3::UnitY()), sc);
  // Backrest with boards on tilted supports.
  if (g.p(0.55)) {
    const double bh = g.u(0.25, 0.45), tilt = g.u(0.05, 0.3);
    const Mat3 R = rot_x(-tilt);
    const Vec3 o(0, H, -D / 2 + 0.02);
    for (int p = 0; p < pairs; ++p) {
      const double x = -ex + 2 * ex * p / (pairs - 1);
      g.add("back_support", transformed(make_bar(Vec3(x, -0.05, -0.03), Vec3(x, bh, -0.03), 0.035, 0.03, Vec3::UnitZ()),
                                        R, o),
            sc);
    }
    const int nb = g.n(1, 4);
    const double bw = g.u(0.05, 0.12);
    for (int i = 0; i < nb; ++i) {
      const double y = bh * (i + 0.7) / (nb + 0.4);
      g.add("back_slat", transformed(make_box_part(Vec3(0, y, 0), Vec3(L / 2, bw / 2, 0.011)), R, o), wood);
    }
    if (g.p(0.5)) {
      const double ah = g.u(0.18, 0.25);
      for (const double sx : {-1.0, 1.0}) {
        const double x = sx * ex;
        g.add("arm_rest", make_tube(bezier(Vec3(x, H - st, D / 2 - 0.05), Vec3(x, H + ah, D / 2 + 0.02),
                                           Vec3(x, H + ah, -D / 4), Vec3(x, H + ah * 0.8, -D / 2 + 0.02), 8),
                                    {0.015}, 8),
              sc);
      }
    }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ sofa
SynthShape make_sofa(Gen& g) {
  const Mat3 I = Mat3::Identity();  // rounded parts use 2 rows per arc: sofas are mostly rounded boxes
  const int seats = g.n(1, 4);
  const double seat_w = g.u(0.5, 0.7);
  const double arm_w = g.p(0.1) ? 0.0 : g.u(0.08, 0.25);
  const double W = seats * seat_w + 2 * arm_w, D = g.u(0.75, 1.0), SH = g.u(0.38, 0.48);
  const double leg_h = g.p(0.2) ? 0.0 : g.u(0.03, 0.15);
  const Vec3f body = g.pick(palette::kFabric);
  const Vec3f cushion = g.p(0.7) ? body : g.jitter(body, 0.12);
  const Vec3f legs = g.p(0.5) ? g.pick(palette::kWood) : g.pick(palette::kDark);
  const double cush_t = g.u(0.08, 0.16);
  const double base_top = SH - cush_t;
  const double back_t = g.u(0.12, 0.25);
  const double BH = g.u(0.7, 0.95);  // back top height
  const double rad = g.u(0.01, 0.05);
  // Base frame.
  g.add("base", make_rounded_box(Vec3(0, (leg_h + base_top) / 2, 0), Vec3(W / 2, (base_top - leg_h) / 2, D / 2), rad, I, 2),
        body);
  // Back.
  const Vec3 back_c(0, (leg_h + BH) / 2, -D / 2 + back_t / 2);
  g.add("back", make_rounded_box(back_c, Vec3(W / 2 - arm_w * 0.5, (BH - leg_h) / 2, back_t / 2), rad, I, 2), body);
  // Seat cushions.
  const double inner = W / 2 - arm_w;
  const double cd = D - back_t;
  for (int i = 0; i < seats; ++i) {
    const double x = -inner + seat_w * (i + 0.5);
    g.add("seat_cushion", make_rounded_box(Vec3(x, base_top + cush_t / 2 - 0.005, -D / 2 + back_t + cd / 2),
                                           Vec3(seat_w / 2 - 0.004, cush_t / 2, cd / 2 - 0.004), g.u(0.02, cush_t / 2), I, 2),
          cushion);
  }
  // Back cushions.
  if (g.p(0.6)) {
    const double bt = g.u(0.1, 0.18), bh = (BH - SH) * g.u(0.7, 0.95);
    const Mat3 R = rot_x(-g.u(0.05, 0.2));
    for (int i = 0; i < seats; ++i) {
      const double x = -inner + seat_w * (i + 0.5);
      g.add("back_cushion",
            transformed(make_rounded_box(Vec3(x, bh / 2, bt / 2), Vec3(seat_w / 2 - 0.004, bh / 2, bt / 2), 0.04, I, 2), R,
                        Vec3(0, SH - 0.01, -D / 2 + back_t - 0.03)),
            cushion);
    }
  }
  // Arms.
  if (arm_w > 0) {
    const double AH = g.u(0.55, std::min(0.8, BH));
    const bool rolled = g.p(0.35);
    for (const double sx : {-1.0, 1.0}) {
      const double x = sx * (W / 2 - arm_w / 2);
      g.add("arm", make_rounded_box(Vec3(x, (leg_h + AH) / 2, 0), Vec3(arm_w / 2, (AH - leg_h) / 2, D / 2), rad, I, 2), body);
      if (rolled)
        g.add("arm_roll", make_cylinder(Vec3(x, AH, -D / 2), Vec3(x, AH, D / 2 + 0.01), arm_w * 0.6, 16), body);
    }
  }
  // Chaise extension on one side.
  if (seats >= 2 && g.p(0.2)) {
    const double sx = g.p(0.5) ? 1 : -1;
    const double ext = g.u(0.4, 0.7);
    const double x = sx * (inner - seat_w / 2);
    g.add("chaise", make_rounded_box(Vec3(x, (leg_h + SH) / 2, D / 2 + ext / 2 - 0.02),
                                     Vec3(seat_w / 2, (SH - leg_h) / 2, ext / 2), rad, I, 2),
          cushion);
  }
  // Throw pillows.
  if (g.p(0.4)) {
    const int n = g.n(1, 2);
    const Vec3f pc = g.pick(palette::kFabric);
    for (int i = 0; i < n; ++i) {
      const double sx = i == 0 ? -1 : 1;
      g.add("pillow", make_rounded_box(Vec3(sx * (inner - 0.2), SH + 0.18, -D / 2 + back_t + 0.1),
                                       Vec3(0.18, 0.17, 0.06), 0.05, rot_x(-0.3) * rot_z(sx * 0.2), 2),
            pc);
    }
  }
  // Legs.
  if (leg_h > 0) {
    const int style = g.n(0, 2);
    const double s = g.u(0.03, 0.06);
    const int per_side = W > 2.0 ? 3 : 2;
    for (int i = 0; i < per_side; ++i) {
      const double x = -W / 2 + s + (W - 2 * s) * i / (per_side - 1);
      for (const double sz : {-1.0, 1.0})
        add_leg(g, "leg", style, Vec3(x, 0, sz * (D / 2 - s)), Vec3(x, leg_h + 0.02, sz * (D / 2 - s)), s, legs);
    }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ cabinet
SynthShape make_cabinet(Gen& g) {
  const double W = g.u(0.4, 1.3), H = g.u(0.5, 2.0), D = g.u(0.3, 0.62);
  const double t = g.u(0.015, 0.03);
  const Vec3f body = g.p(0.6) ? g.pick(palette::kWood) : g.pick(palette::kPlastic);
  const Vec3f front = g.p(0.6) ? body : g.pick(palette::kPaint);
  const Vec3f metal = g.pick(palette::kMetal);
  // Base: plinth, legs or nothing.
  const int base = g.choose({0.4, 0.35, 0.25});
  double y0 = 0;
  if (base == 0) {
    y0 = g.u(0.05, 0.12);
    g.add("plinth", make_box_part(Vec3(0, y0 / 2 + 0.002, 0.0), Vec3(W / 2 - 0.03, y0 / 2, D / 2 - 0.04)), body);
  } else if (base == 1) {
    y0 = g.u(0.06, 0.2);
    const double s = g.u(0.025, 0.05);
    const int style = g.n(0, 2);
    const Vec3f leg_c = g.p(0.5) ? metal : body;
    add_four_legs(g, style, W / 2 - s, D / 2 - s, y0 + 0.01, s, 0.0, leg_c);
  }
  const double h = H - y0;
  auto panel = [&](const std::string& name, const Vec3& c, const Vec3& half) {
    g.add(name, make_box_part(c, half), body);
  };
  panel("side", Vec3(-W / 2 + t / 2, y0 + h / 2, 0), Vec3(t / 2, h / 2, D / 2));
  panel("side", Vec3(W / 2 - t / 2, y0 + h / 2, 0), Vec3(t / 2, h / 2, D / 2));
  panel("bottom", Vec3(0, y0 + t / 2, 0), Vec3(W / 2 - t * 0.5, t / 2, D / 2));
  const double over = g.p(0.4) ? g.u(0.01, 0.04) : 0.0;
  panel("top", Vec3(0, H - t / 2, over / 2), Vec3(W / 2 + over, t / 2, D / 2 + over / 2));
  panel("back", Vec3(0, y0 + h / 2, -D / 2 + t / 2), Vec3(W / 2 - t * 0.5, h / 2 - t * 0.5, t / 2));
  // Front layout.
  const int layout = g.choose({0.35, 0.25, 0.2, 0.2});  // doors, drawers, drawers over doors, open shelves
  const double gap = 0.004, fz = D / 2 + t / 2;
  const double inner_w = W - 2 * t, inner_h = h - 2 * t;
  const double zc = y0 + t;  // bottom of the opening
  auto handle = [&](double x, double y, bool vertical) {
    if (g.p(0.55)) {
      const double len = g.u(0.06, 0.16);
      const Vec3 d = vertical ? Vec3(0, len / 2, 0) : Vec3(len / 2, 0, 0);
      const Vec3 c(x, y, fz + t / 2 + 0.025);
      g.add("handle", make_bar(c - d, c + d, 0.012, 0.012, Vec3::UnitZ()), metal);
      g.add("handle_post", make_cylinder(c - 0.8 * d - Vec3(0, 0, 0.03), c - 0.8 * d + Vec3(0, 0, 0.004), 0.004, 8),
            metal);
      g.add("handle_post", make_cylinder(c + 0.8 * d - Vec3(0, 0, 0.03), c + 0.8 * d + Vec3(0, 0, 0.004), 0.004, 8),
            metal);
    } else {
      const Vec3 c(x, y, fz + t / 2);
      g.add("knob", make_cylinder(c - Vec3(0, 0, 0.01), c + Vec3(0, 0, 0.02), 0.006, 8), metal);
      g.add("knob", make_ellipsoid(c + Vec3(0, 0, 0.025), Vec3(0.015, 0.015, 0.01), Mat3::Identity(), 3), metal);
    }
  };
  auto doors = [&](double ylo, double yhi) {
    const int cols = inner_w > 0.7 ? 2 : (g.p(0.3) ? 2 : 1);
    const double dw = inner_w / cols;
    for (int c = 0; c < cols; ++c) {
      const double x = -inner_w / 2 + dw * (c + 0.5);
      g.add("door", make_box_part(Vec3(x, 0.5 * (ylo + yhi), fz), Vec3(dw / 2 - gap, 0.5 * (yhi - ylo) - gap, t / 2)),
            front);
      const double hx = cols == 1 ? x + dw * 0.38 : (c == 0 ? x + dw * 0.38 : x - dw * 0.38);
      handle(hx, 0.5 * (ylo + yhi) + (yhi - ylo) * (yhi > 1.2 ? -0.15 : 0.0), true);
    }
  };
  auto drawers = [&](double ylo, double yhi, int n) {
    for (int i = 0; i < n; ++i) {
      const double a = ylo + (yhi - ylo) * i / n, b = ylo + (yhi - ylo) * (i + 1) / n;
      g.add("drawer", make_box_part(Vec3(0, 0.5 * (a + b), fz), Vec3(inner_w / 2 - gap, 0.5 * (b - a) - gap, t / 2)),
            front);
      handle(0, 0.5 * (a + b), false);
    }
  };
  if (layout == 0) {
    doors(zc, zc + inner_h);
  } else if (layout == 1) {
    drawers(zc, zc + inner_h, std::max(2, std::min(6, static_cast<int>(inner_h / g.u(0.15, 0.3)))));
  } else if (layout == 2) {
    const double split = zc + inner_h * g.u(0.55, 0.8);
    doors(zc, split);
    drawers(split, zc + inner_h, g.n(1, 2));
  } else {
    const int shelves = std::max(1, std::min(5, static_cast<int>(inner_h / g.u(0.25, 0.4))));
    for (int i = 1; i <= shelves; ++i) {
      const double y = zc + inner_h * i / (shelves + 1);
      g.add("shelf", make_box_part(Vec3(0, y, 0.01), Vec3(inner_w / 2 + 0.002, t / 2, D / 2 - t)), body);
    }
    if (inner_w > 0.8 && g.p(0.6))
      g.add("divider", make_box_part(Vec3(0, zc + inner_h / 2, 0.01), Vec3(t / 2, inner_h / 2, D / 2 - t)), body);
  }
  return g.b.build();
}

}  // namespace sdfkit
