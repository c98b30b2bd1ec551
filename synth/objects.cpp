// Object families: display, lamp, speaker, rifle, phone. +y up, front towards +z.
// Random draws are taken one per statement so that their order never depends on argument evaluation order.
#include "synth/generators.h"

#include <cmath>

namespace sdfkit {

// ------------------------------------------------------------------------------------------------ display
SynthShape make_display(Gen& g) {
  const double W = g.u(0.35, 0.9);
  const double H = W * g.u(0.5, 0.8);
  const double pt = g.u(0.012, 0.04);  // panel thickness
  const double bez = g.u(0.006, 0.035);
  const bool crt = g.p(0.15);
  const Vec3f case_c = g.pick(palette::kPlastic);
  const Vec3f screen_c = g.pick(palette::kDark);
  const double stand_h = g.u(0.06, 0.2);
  const double yc = stand_h + H / 2;  // panel centre height
  // Screen: a dark slab recessed behind the bezel bars (the bezel is a frame around it).
  g.add("screen", make_box_part(Vec3(0, yc, -0.002), Vec3(W / 2 - bez * 0.5, H / 2 - bez * 0.5, pt / 2)), screen_c);
  const double bz = pt / 2 + 0.003;  // bezel depth (half)
  g.add("bezel", make_box_part(Vec3(0, yc + H / 2 - bez / 2, 0), Vec3(W / 2, bez / 2, bz)), case_c);
  g.add("bezel", make_box_part(Vec3(0, yc - H / 2 + bez / 2, 0), Vec3(W / 2, bez / 2, bz)), case_c);
  g.add("bezel", make_box_part(Vec3(-W / 2 + bez / 2, yc, 0), Vec3(bez / 2, H / 2 - bez * 0.9, bz)), case_c);
  g.add("bezel", make_box_part(Vec3(W / 2 - bez / 2, yc, 0), Vec3(bez / 2, H / 2 - bez * 0.9, bz)), case_c);
  if (g.p(0.3))
    g.add("chin", make_box_part(Vec3(0, yc - H / 2 - 0.02, 0), Vec3(W / 2, 0.025, bz)), case_c);
  // Back housing.
  if (crt) {
    const double depth = W * g.u(0.6, 0.9);
    const double s = g.u(0.35, 0.6);
    std::array<Vec3, 8> c;
    for (int i = 0; i < 8; ++i) {
      const double sx = (i & 1) ? 1 : -1, sy = (i & 2) ? 1 : -1;
      const bool back = !(i & 4);
      const double f = back ? s : 0.97;
      c[i] = Vec3(sx * f * W / 2, yc + sy * f * H / 2 + (back ? -0.05 * H : 0.0), back ? -depth : -pt / 2 + 0.001);
    }
    g.add("tube_housing", make_hexahedron(c), case_c);
  } else if (g.p(0.6)) {
    const double hd = g.u(0.02, 0.06);
    g.add("back_housing", make_rounded_box(Vec3(0, yc - H * 0.05, -pt / 2 - hd / 2 + 0.002),
                                           Vec3(W * 0.35, H * 0.3, hd / 2), hd * 0.4),
          case_c);
  }
  // Stand.
  const int stand = g.choose({0.45, 0.25, 0.15, 0.15});  // neck + base, two feet, bent arm, none (wall / box base)
  const double zb = crt ? -W * 0.3 : -pt / 2 - 0.03;
  if (stand == 0) {
    const double nw = g.u(0.03, 0.09);
    g.add("neck", make_bar(Vec3(0, 0.005, zb), Vec3(0, yc - H * 0.1, zb), nw, 0.02, Vec3::UnitZ()), case_c);
    const int base = g.n(0, 2);
    const double bw = W * g.u(0.25, 0.5);
    const double bd = g.u(0.12, 0.25);
    if (base == 0)
      g.add("base", make_box_part(Vec3(0, 0.008, zb + 0.02), Vec3(bw / 2, 0.008, bd / 2)), case_c);
    else if (base == 1)
      g.add("base", make_ellipsoid(Vec3(0, 0.01, zb + 0.02), Vec3(bw / 2, 0.012, bd / 2), Mat3::Identity(), 5), case_c);
    else
      g.add("base", make_cylinder(Vec3(0, 0, zb + 0.02), Vec3(0, 0.015, zb + 0.02), bd / 2, 24), case_c);
  } else if (stand == 1) {
    const double fx = W * g.u(0.25, 0.45);
    const double fd = g.u(0.12, 0.22);
    for (const double sx : {-1.0, 1.0}) {
      g.add("foot_post", make_bar(Vec3(sx * fx, 0.0, -0.01), Vec3(sx * fx, yc - H * 0.35, -0.01), 0.025, 0.012,
                                  Vec3::UnitZ()),
            case_c);
      g.add("foot", make_bar(Vec3(sx * fx, 0.008, -fd / 2), Vec3(sx * fx, 0.008, fd / 2), 0.03, 0.016, Vec3::UnitY()),
            case_c);
    }
  } else if (stand == 2) {
    const double r = g.u(0.008, 0.015);
    const std::vector<Vec3> path = {Vec3(0, 0.01, zb - 0.06), Vec3(0, yc * 0.5, zb - 0.08), Vec3(0, yc, zb - 0.01)};
    g.add("arm", make_tube(path, {r}, 10), g.pick(palette::kMetal));
    g.add("base", make_cylinder(Vec3(0, 0, zb - 0.06), Vec3(0, 0.012, zb - 0.06), g.u(0.07, 0.12), 20), case_c);
  } else {
    g.add("base", make_box_part(Vec3(0, stand_h / 2, -0.02), Vec3(W * 0.3, stand_h / 2, g.u(0.04, 0.1))), case_c);
  }
  if (g.p(0.25)) {  // buttons on the bezel
    const int n = g.n(2, 5);
    for (int i = 0; i < n; ++i)
      g.add("button", make_box_part(Vec3(W * 0.3 + i * 0.02, yc - H / 2 + bez / 2, bz + 0.002),
                                    Vec3(0.006, std::min(0.006, bez * 0.4), 0.003)),
            g.pick(palette::kDark));
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ lamp
namespace {
void add_shade(Gen& g, const Vec3& top, const Vec3& dir, double len, double r_top, double r_bottom, const Vec3f& c,
               const Vec3f& bulb) {
  const Vec3 d = dir.normalized();
  g.add("shade", make_cone(top, top + len * d, r_top, r_bottom, 20), c);
  g.add("bulb", make_ellipsoid(top + 0.85 * len * d, Vec3::Constant(std::min(r_bottom, r_top + 0.02) * 0.45),
                               Mat3::Identity(), 3),
        bulb);
}
}  // namespace

SynthShape make_lamp(Gen& g) {
  const Vec3f metal = g.pick(palette::kMetal);
  const Vec3f shade_c = g.p(0.5) ? g.pick(palette::kLight) : g.pick(palette::kPlastic);
  const Vec3f bulb = Vec3f(1.0f, 0.95f, 0.7f);
  const int kind = g.choose({0.28, 0.3, 0.15, 0.15, 0.12});  // desk arm, table/floor, arc, multi-arm, pendant
  // Base.
  double base_top = 0;
  if (kind != 4) {
    const int b = g.n(0, 2);
    const double r = g.u(0.07, 0.16);
    const double bh = g.u(0.015, 0.05);
    if (b == 0)
      g.add("base", make_cylinder(Vec3(0, 0, 0), Vec3(0, bh, 0), r, 24), metal);
    else if (b == 1)
      g.add("base", make_box_part(Vec3(0, bh / 2, 0), Vec3(r, bh / 2, r * 0.8)), metal);
    else
      g.add("base", make_ellipsoid(Vec3(0, bh * 0.5, 0), Vec3(r, bh, r), Mat3::Identity(), 5), metal);
    base_top = bh;
  }
  if (kind == 0) {
    // Articulated desk lamp: two arm segments with joints, head cone.
    const double a1 = g.u(0.25, 0.45), a2 = g.u(0.25, 0.45);
    const double ang1 = g.u(-0.5, 0.3), ang2 = g.u(0.6, 1.6);  // from vertical, tilting towards +z
    const double rr = g.u(0.006, 0.012);
    const Vec3 j0(0, base_top, 0);
    const Vec3 j1 = j0 + a1 * Vec3(0, std::cos(ang1), std::sin(ang1));
    const Vec3 j2 = j1 + a2 * Vec3(0, std::cos(ang2), std::sin(ang2));
    const bool twin = g.p(0.5);
    for (const double dx : twin ? std::vector<double>{-0.015, 0.015} : std::vector<double>{0.0}) {
      g.add("arm", make_cylinder(j0 + Vec3(dx, 0, 0), j1 + Vec3(dx, 0, 0), rr, 8), metal);
      g.add("arm", make_cylinder(j1 + Vec3(dx, 0, 0), j2 + Vec3(dx, 0, 0), rr, 8), metal);
    }
    g.add("joint", make_cylinder(j0 - Vec3(0.025, -0.01, 0), j0 + Vec3(0.025, 0.01, 0), 0.018, 12), metal);
    g.add("joint", make_cylinder(j1 - Vec3(0.025, 0, 0), j1 + Vec3(0.025, 0, 0), 0.016, 12), metal);
    if (g.p(0.5))
      g.add("spring", make_cylinder(j0 + Vec3(0.03, 0.05, 0), j1 * 0.7 + j0 * 0.3 + Vec3(0.03, 0, 0), 0.004, 6), metal);
    const double hang = g.u(2.0, 2.9);  // head direction (mostly downwards)
    const Vec3 hd(0, std::cos(hang), std::sin(hang));
    const double sl = g.u(0.1, 0.2), rt = g.u(0.015, 0.03), rb = g.u(0.06, 0.11);
    add_shade(g, j2, hd, sl, rt, rb, shade_c, bulb);
  } else if (kind == 1) {
    // Straight pole with a frustum shade, sometimes with a harp and finial.
    const double Hp = g.p(0.5) ? g.u(0.3, 0.6) : g.u(1.2, 1.7);
    const double pr = g.u(0.008, 0.02);
    const bool bulbous = Hp < 0.7 && g.p(0.4);
    if (bulbous) {
      g.add("body", make_ellipsoid(Vec3(0, base_top + Hp * 0.3, 0), Vec3(0.08, Hp * 0.3, 0.08), Mat3::Identity(), 6),
            g.pick(palette::kPaint));
    }
    g.add("pole", make_cylinder(Vec3(0, base_top - 0.005, 0), Vec3(0, base_top + Hp, 0), pr, 10), metal);
    const double sl = Hp < 0.7 ? g.u(0.15, 0.3) : g.u(0.25, 0.4);
    const double rt = sl * g.u(0.3, 0.8), rb = sl * g.u(0.7, 1.3);
    const Vec3 top(0, base_top + Hp + sl * 0.6, 0);
    g.add("shade", make_cone(top, top - Vec3(0, sl, 0), rt, rb, 24), shade_c);
    g.add("bulb", make_ellipsoid(top - Vec3(0, sl * 0.55, 0), Vec3::Constant(std::min(rt, rb) * 0.5), Mat3::Identity(), 3),
          bulb);
    if (g.p(0.4)) {
      const auto harp = arc(top - Vec3(0, sl * 0.5, 0), Vec3::UnitX(), Vec3::UnitY(), rt * 0.8, 0.0, M_PI, 9);
      g.add("harp", make_tube(harp, {0.004}, 6), metal);
      g.add("finial", make_ellipsoid(top + Vec3(0, 0.015, 0), Vec3(0.012, 0.02, 0.012), Mat3::Identity(), 3), metal);
    }
  } else if (kind == 2) {
    // Arc lamp: a swept tube rising and bending over, a hanging shade.
    const double Hh = g.u(1.2, 1.9), reach = g.u(0.6, 1.2);
    const double r = g.u(0.01, 0.02);
    const auto path = bezier(Vec3(0, base_top - 0.005, 0), Vec3(0, Hh * 1.1, 0), Vec3(0, Hh * 1.05, reach * 0.6),
                             Vec3(0, Hh * 0.85, reach), 14);
    g.add("arc", make_tube(path, {r}, 10), metal);
    const double sl = g.u(0.12, 0.25), rb = g.u(0.12, 0.25);
    add_shade(g, path.back() - Vec3(0, 0.01, 0), -Vec3::UnitY(), sl, g.u(0.02, 0.05), rb, shade_c, bulb);
  } else if (kind == 3) {
    // Several curved arms from a central pole, each with a small shade.
    const double Hp = g.u(0.4, 1.6);
    g.add("pole", make_cylinder(Vec3(0, base_top - 0.005, 0), Vec3(0, base_top + Hp, 0), 0.015, 10), metal);
    const int arms = g.n(2, 6);
    const double reach = g.u(0.15, 0.4), rise = g.u(-0.1, 0.25), phase = g.u(0, M_PI);
    const bool up = g.p(0.5);
    const double sl = g.u(0.06, 0.14), rb = g.u(0.04, 0.09);
    for (int a = 0; a < arms; ++a) {
      const double ang = phase + 2 * M_PI * a / arms;
      const Vec3 dir(std::cos(ang), 0, std::sin(ang));
      const Vec3 s(0, base_top + Hp * 0.85, 0);
      const Vec3 e = s + reach * dir + Vec3(0, rise, 0);
      const auto path = bezier(s, s + 0.5 * reach * dir - Vec3(0, 0.05, 0), e - Vec3(0, 0.08, 0), e, 8);
      g.add("arm", make_tube(path, {0.007}, 8), metal);
      add_shade(g, e, up ? Vec3(Vec3::UnitY()) : Vec3(-Vec3::UnitY()), sl, 0.015, rb, shade_c, bulb);
    }
  } else {
    // Pendant: ceiling canopy, cord, big shade.
    const double Hc = g.u(1.0, 1.6);
    g.add("canopy", make_cylinder(Vec3(0, Hc, 0), Vec3(0, Hc + 0.03, 0), 0.06, 16), metal);
    const double cord = g.u(0.3, 0.8);
    g.add("cord", make_cylinder(Vec3(0, Hc - cord, 0), Vec3(0, Hc + 0.01, 0), 0.004, 6), g.pick(palette::kDark));
    const double sl = g.u(0.15, 0.35), rb = g.u(0.15, 0.35);
    if (g.p(0.3)) {
      g.add("shade", make_ellipsoid(Vec3(0, Hc - cord - sl * 0.4, 0), Vec3(rb, sl * 0.5, rb), Mat3::Identity(), 6),
            shade_c);
    } else {
      add_shade(g, Vec3(0, Hc - cord + 0.01, 0), -Vec3::UnitY(), sl, g.u(0.02, 0.06), rb, shade_c, bulb);
    }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ speaker
SynthShape make_speaker(Gen& g) {
  const int kind = g.choose({0.35, 0.35, 0.15, 0.15});  // bookshelf, tower, cylinder, subwoofer cube
  double W = g.u(0.15, 0.3), H = g.u(0.25, 0.45), D = g.u(0.18, 0.3);
  if (kind == 1) {
    W = g.u(0.18, 0.3);
    H = g.u(0.8, 1.15);
    D = g.u(0.22, 0.35);
  } else if (kind == 3) {
    W = g.u(0.3, 0.45);
    H = W;
    D = W;
  }
  const Vec3f box_c = g.p(0.6) ? g.pick(palette::kWood) : g.pick(palette::kPlastic);
  const Vec3f drv = g.pick(palette::kDark);
  const Vec3f cone_c = g.pick(palette::kMetal);
  const double feet_h = g.p(0.4) ? g.u(0.02, 0.06) : 0.0;
  const double y0 = feet_h;
  if (kind == 2) {
    const double r = g.u(0.06, 0.12);
    H = g.u(0.15, 0.3);
    g.add("body", make_cylinder(Vec3(0, 0, 0), Vec3(0, H, 0), r, 28), box_c);
    g.add("top_ring", make_torus_part(Vec3(0, H, 0), Vec3::UnitY(), r * 0.7, r * 0.08, 24, 8), drv);
    g.add("grille", make_cylinder(Vec3(0, H * 0.1, 0), Vec3(0, H * 0.8, 0), r * 1.02, 28), g.jitter(drv, 0.1));
    if (g.p(0.5)) {
      for (int i = 0; i < 4; ++i)
        g.add("button", make_cylinder(Vec3(r * 0.3 * (i - 1.5), H, 0.0), Vec3(r * 0.3 * (i - 1.5), H + 0.005, 0.0),
                                      0.008, 8),
              drv);
    }
    return g.b.build();
  }
  g.add("cabinet", make_rounded_box(Vec3(0, y0 + H / 2, 0), Vec3(W / 2, H / 2, D / 2), g.u(0.0, 0.02)), box_c);
  const double fz = D / 2;
  // Drivers from the top: tweeter then woofers.
  std::vector<double> radii;
  if (kind == 3) {
    radii.push_back(W * 0.38);
  } else {
    radii.push_back(g.u(0.015, 0.025));  // tweeter
    const int woofers = kind == 1 ? g.n(1, 3) : 1;
    for (int i = 0; i < woofers; ++i) radii.push_back(std::min(W * 0.42, g.u(0.05, 0.1)));
  }
  double y = y0 + H - 0.03;
  for (size_t i = 0; i < radii.size(); ++i) {
    const double r = radii[i];
    y -= r + 0.02;
    const Vec3 c(0, y, fz);
    y -= r;
    if (i == 0 && kind != 3) {
      g.add("tweeter_plate", make_cylinder(c - Vec3(0, 0, 0.01), c + Vec3(0, 0, 0.004), r * 1.6, 16), drv);
      g.add("tweeter_dome", make_ellipsoid(c + Vec3(0, 0, 0.004), Vec3(r, r, r * 0.6), Mat3::Identity(), 4), cone_c);
      continue;
    }
    const double sr = r * 0.12;
    g.add("surround", make_torus_part(c, Vec3::UnitZ(), r - sr, sr, 28, 8), drv);
    g.add("cone", make_cone(c + Vec3(0, 0, 0.002), c - Vec3(0, 0, r * 0.5), r - sr, r * 0.2, 20), cone_c);
    g.add("dust_cap", make_ellipsoid(c - Vec3(0, 0, 0.0), Vec3(r * 0.25, r * 0.25, r * 0.12), Mat3::Identity(), 3), drv);
    g.add("frame_ring", make_torus_part(c, Vec3::UnitZ(), r + sr * 0.5, sr * 0.6, 28, 6), drv);
  }
  // Bass reflex port.
  if (g.p(0.6) && y - y0 > 0.06) {
    const Vec3 c(0, std::max(y0 + 0.04, y - 0.03), fz);
    g.add("port", make_torus_part(c, Vec3::UnitZ(), 0.02, 0.005, 16, 6), drv);
    g.add("port_hole", make_cylinder(c - Vec3(0, 0, 0.01), c + Vec3(0, 0, 0.001), 0.016, 12), Vec3f(0.02f, 0.02f, 0.02f));
  }
  // Grille frame around the front.
  if (g.p(0.3)) {
    const double b = 0.012;
    const double fzz = fz + 0.025;
    g.add("grille_frame", make_box_part(Vec3(0, y0 + H - b, fzz), Vec3(W / 2 - b, b / 2, 0.005)), box_c);
    g.add("grille_frame", make_box_part(Vec3(0, y0 + b, fzz), Vec3(W / 2 - b, b / 2, 0.005)), box_c);
    for (const double sx : {-1.0, 1.0})
      g.add("grille_frame", make_box_part(Vec3(sx * (W / 2 - b), y0 + H / 2, fzz), Vec3(b / 2, H / 2 - b / 2, 0.005)),
            box_c);
    for (const double sx : {-1.0, 1.0})
      for (const double sy : {-1.0, 1.0})
        g.add("grille_peg", make_cylinder(Vec3(sx * (W / 2 - b), y0 + H / 2 + sy * (H / 2 - b), fz - 0.005),
                                          Vec3(sx * (W / 2 - b), y0 + H / 2 + sy * (H / 2 - b), fzz), 0.004, 6),
              box_c);
  }
  // Feet or spikes.
  if (feet_h > 0) {
    const bool spikes = g.p(0.5);
    for (const double sx : {-1.0, 1.0})
      for (const double sz : {-1.0, 1.0}) {
        const Vec3 top(sx * (W / 2 - 0.03), feet_h + 0.005, sz * (D / 2 - 0.03));
        if (spikes)
          g.add("spike", make_cone(Vec3(top.x(), 0.0, top.z()), top, 0.0, 0.015, 10), cone_c);
        else
          g.add("foot", make_cylinder(Vec3(top.x(), 0.0, top.z()), top, 0.018, 10), drv);
      }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ rifle
SynthShape make_rifle(Gen& g) {
  // Length along z, muzzle at +z, receiver around the origin.
  const double rl = g.u(0.18, 0.3), rh = g.u(0.05, 0.09), rw = g.u(0.03, 0.05);
  const Vec3f metal = g.pick(palette::kDark);
  const Vec3f furn = g.p(0.5) ? g.pick(palette::kWood) : g.pick(palette::kDark, 0.08);
  const Vec3f steel = g.pick(palette::kMetal);
  g.add("receiver", make_box_part(Vec3(0, 0, 0), Vec3(rw / 2, rh / 2, rl / 2)), metal);
  // Barrel.
  const double bl = g.u(0.35, 0.65), br = g.u(0.008, 0.014);
  const double by = rh * g.u(0.05, 0.25);
  const Vec3 b0(0, by, rl / 2 - 0.02), b1(0, by, rl / 2 + bl);
  g.add("barrel", make_cylinder(b0, b1, br, 12), metal);
  if (g.p(0.5)) g.add("muzzle_brake", make_cylinder(b1 - Vec3(0, 0, 0.05), b1 + Vec3(0, 0, 0.01), br * 1.7, 12), metal);
  // Handguard / fore-end.
  if (g.p(0.85)) {
    const double hl = bl * g.u(0.3, 0.7), hr = g.u(0.02, 0.035);
    if (g.p(0.5)) {
      g.add("handguard", make_cylinder(Vec3(0, by, rl / 2 - 0.01), Vec3(0, by, rl / 2 + hl), hr, 14), furn);
    } else {
      g.add("handguard", make_box_part(Vec3(0, by - hr * 0.4, rl / 2 + hl / 2 - 0.01), Vec3(hr, hr * 1.1, hl / 2)), furn);
    }
    if (g.p(0.25)) {  // bipod folded down
      const double la = g.u(0.15, 0.25);
      const Vec3 mount(0, by - hr, rl / 2 + hl * 0.8);
      for (const double sx : {-1.0, 1.0})
        g.add("bipod_leg", make_cylinder(mount, mount + la * Vec3(sx * 0.35, -0.92, 0.15).normalized(), 0.005, 8), steel);
    }
  }
  // Front sight.
  if (g.p(0.6))
    g.add("front_sight", make_box_part(b1 - Vec3(0, -br - 0.01, 0.06), Vec3(0.003, 0.012, 0.006)), metal);
  // Stock.
  const double sl = g.u(0.22, 0.36), butt_h = g.u(0.1, 0.16), drop = g.u(0.02, 0.07);
  const double sw = rw * g.u(0.8, 1.2);
  const double z0 = -rl / 2 + 0.01, z1 = -rl / 2 - sl;
  if (g.p(0.25)) {
    // Skeleton stock: a frame of bars around an opening.
    const Vec3 top0(0, rh * 0.3, z0), top1(0, rh * 0.3 - drop, z1), bot1(0, rh * 0.3 - drop - butt_h, z1),
        bot0(0, -rh * 0.4, z0);
    const double t = g.u(0.012, 0.02);
    g.add("stock_bar", make_bar(top0, top1, sw, t, Vec3::UnitY()), furn);
    g.add("stock_bar", make_bar(bot0, bot1, sw, t, Vec3::UnitY()), furn);
    g.add("butt_plate", make_box_part(0.5 * (top1 + bot1), Vec3(sw * 0.6, butt_h / 2 + t, 0.012)), furn);
  } else {
    std::array<Vec3, 8> c;
    for (int i = 0; i < 8; ++i) {
      const double sx = (i & 1) ? 1 : -1;
      const bool top = i & 2, front = i & 4;
      const double z = front ? z0 : z1;
      const double y = front ? (top ? rh * 0.35 : -rh * 0.45) : (top ? rh * 0.3 - drop : rh * 0.3 - drop - butt_h);
      c[i] = Vec3(sx * sw / 2 * (front ? 0.9 : 1.0), y, z);
    }
    g.add("stock", make_hexahedron(c), furn);
    if (g.p(0.4))
      g.add("cheek_rest", make_box_part(Vec3(0, rh * 0.3 - drop * 0.6 + 0.012, z1 + sl * 0.45), Vec3(sw * 0.4, 0.012, sl * 0.25)),
            furn);
  }
  // Pistol grip.
  const double ga = g.u(0.25, 0.55), gl = g.u(0.09, 0.13);
  {
    const Vec3 top(0, -rh / 2 + 0.01, -rl * 0.25);
    const Vec3 bot = top + gl * Vec3(0, -std::cos(ga), -std::sin(ga));
    g.add("grip", make_bar(top, bot, rw * 0.9, 0.03, Vec3::UnitZ()), furn);
  }
  // Trigger guard (a half ring) and trigger.
  const Vec3 tg(0, -rh / 2, -rl * 0.05);
  const auto guard = arc(tg, Vec3::UnitZ(), -Vec3::UnitY(), g.u(0.025, 0.035), 0.0, M_PI, 9);
  g.add("trigger_guard", make_tube(guard, {0.003}, 6), metal);
  g.add("trigger", make_bar(tg + Vec3(0, 0.004, 0), tg + Vec3(0, -0.02, -0.006), 0.004, 0.004, Vec3::UnitZ()), steel);
  // Magazine.
  if (g.p(0.8)) {
    const double ml = g.u(0.08, 0.2), mw = g.u(0.025, 0.04), mt = g.u(0.0, 0.35);
    const Vec3 top(0, -rh / 2 + 0.015, rl * 0.15);
    const Vec3 bot = top + ml * Vec3(0, -std::cos(mt), std::sin(mt));
    g.add("magazine", make_bar(top, bot, rw * 0.7, mw, Vec3::UnitZ()), metal);
  }
  // Scope or carry handle.
  const int top = g.choose({0.5, 0.15, 0.35});
  if (top == 0) {
    const double sr = g.u(0.012, 0.02), slen = g.u(0.2, 0.35), sh = rh / 2 + g.u(0.03, 0.05);
    const double zc = g.u(-0.05, 0.05);
    g.add("scope_tube", make_cylinder(Vec3(0, sh, zc - slen / 2), Vec3(0, sh, zc + slen / 2), sr, 14), metal);
    g.add("scope_objective", make_cone(Vec3(0, sh, zc + slen / 2 - 0.01), Vec3(0, sh, zc + slen / 2 + 0.06), sr, sr * 1.7, 14),
          metal);
    g.add("scope_eyepiece", make_cone(Vec3(0, sh, zc - slen / 2 + 0.01), Vec3(0, sh, zc - slen / 2 - 0.05), sr, sr * 1.4, 14),
          metal);
    g.add("scope_turret", make_cylinder(Vec3(0, sh, zc), Vec3(0, sh + sr + 0.015, zc), sr * 0.6, 10), metal);
    for (const double dz : {-slen * 0.3, slen * 0.3}) {
      g.add("scope_ring", make_torus_part(Vec3(0, sh, zc + dz), Vec3::UnitZ(), sr + 0.002, 0.003, 16, 6), steel);
      g.add("scope_mount", make_bar(Vec3(0, rh / 2 - 0.005, zc + dz), Vec3(0, sh - sr, zc + dz), 0.012, 0.008, Vec3::UnitZ()),
            steel);
    }
  } else if (top == 1) {
    const double hh = g.u(0.03, 0.05);
    g.add("carry_handle", make_bar(Vec3(0, rh / 2 + hh, -rl * 0.35), Vec3(0, rh / 2 + hh, rl * 0.3), 0.012, 0.01,
                                   Vec3::UnitY()),
          metal);
    for (const double z : {-rl * 0.35, rl * 0.3})
      g.add("carry_post", make_bar(Vec3(0, rh / 2 - 0.005, z), Vec3(0, rh / 2 + hh + 0.004, z), 0.012, 0.012, Vec3::UnitZ()),
            metal);
  } else {
    g.add("rear_sight", make_box_part(Vec3(0, rh / 2 + 0.008, -rl * 0.3), Vec3(0.006, 0.008, 0.01)), metal);
  }
  // Bolt handle.
  g.add("bolt_handle", make_cylinder(Vec3(0, rh * 0.2, -rl * 0.1), Vec3(rw / 2 + 0.035, rh * 0.1, -rl * 0.1), 0.004, 8),
        steel);
  g.add("bolt_knob", make_ellipsoid(Vec3(rw / 2 + 0.04, rh * 0.1, -rl * 0.1), Vec3::Constant(0.009), Mat3::Identity(), 3),
        steel);
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ phone
SynthShape make_phone(Gen& g) {
  const int kind = g.choose({0.6, 0.25, 0.15});  // smartphone, keypad phone, cordless with antenna
  const double W = g.u(0.055, 0.08);
  const double H = kind == 0 ? g.u(0.12, 0.17) : g.u(0.1, 0.15);
  const double T = kind == 0 ? g.u(0.007, 0.012) : g.u(0.012, 0.022);
  const Vec3f body_c = g.pick(palette::kPlastic);
  const Vec3f screen_c = g.pick(palette::kDark);
  const Vec3f key_c = g.pick(palette::kPlastic);
  g.add("body", make_rounded_box(Vec3(0, 0, 0), Vec3(W / 2, H / 2, T / 2), g.u(0.002, std::min(0.01, T / 2))), body_c);
  const double m = g.u(0.002, 0.006);
  if (kind == 0) {
    g.add("screen", make_box_part(Vec3(0, 0, T / 2 - 0.0003), Vec3(W / 2 - m, H / 2 - m * 1.5, 0.0006)), screen_c);
    g.add("earpiece", make_box_part(Vec3(0, H / 2 - m * 0.8, T / 2 + 0.0002), Vec3(W * 0.12, 0.0008, 0.0005)), body_c);
    // Camera bump with lenses.
    const int lenses = g.n(1, 3);
    const double lr = g.u(0.003, 0.006);
    const bool row = g.p(0.5);
    const Vec3 bc(-W / 2 + 0.012 + lr, H / 2 - 0.012 - lr, -T / 2);
    const double bw = row ? lenses * (2.4 * lr) : 2.4 * lr, bh = row ? 2.4 * lr : lenses * (2.4 * lr);
    g.add("camera_bump", make_rounded_box(bc + Vec3(bw / 2 - 1.2 * lr, -bh / 2 + 1.2 * lr, 0.0),
                                          Vec3(bw / 2 + 0.002, bh / 2 + 0.002, 0.0015), 0.002),
          body_c);
    for (int i = 0; i < lenses; ++i) {
      const Vec3 c = bc + (row ? Vec3(2.4 * lr * i, 0, 0) : Vec3(0, -2.4 * lr * i, 0));
      g.add("lens", make_cylinder(c - Vec3(0, 0, 0.0025), c + Vec3(0, 0, 0.0005), lr, 14), screen_c);
    }
  } else {
    // Screen in the upper part, a grid of keys below.
    const double sh = H * g.u(0.3, 0.45);
    const double sy = H / 2 - m - sh / 2 - 0.005;
    g.add("screen", make_box_part(Vec3(0, sy, T / 2), Vec3(W / 2 - m - 0.004, sh / 2, 0.0008)), screen_c);
    const double ky0 = sy - sh / 2 - 0.006, ky1 = -H / 2 + 0.008;
    const int rows = 5, cols = 3;
    const double kw = (W - 2 * m - 0.01) / cols, kh = (ky0 - ky1) / rows;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        const Vec3 kc(-W / 2 + m + 0.005 + kw * (c + 0.5), ky0 - kh * (r + 0.5), T / 2);
        g.add("key", make_rounded_box(kc, Vec3(kw * 0.38, kh * 0.35, 0.0015), 0.0008, Mat3::Identity(), 1), key_c);
      }
    if (kind == 2) {
      const double al = g.u(0.03, 0.08);
      const double ar = g.u(0.002, 0.004);
      const Vec3f ac = g.pick(palette::kDark);
      g.add("antenna", make_cylinder(Vec3(W * 0.3, H / 2 - 0.005, -T * 0.1), Vec3(W * 0.3, H / 2 + al, -T * 0.1), ar, 8),
            ac);
    }
  }
  // Side buttons.
  const int nb = g.n(1, 3);
  for (int i = 0; i < nb; ++i)
    g.add("side_button", make_box_part(Vec3(W / 2, H * (0.25 - 0.12 * i), 0), Vec3(0.001, 0.008, T * 0.25)), body_c);
  return g.b.build();
}

}  // namespace sdfkit
