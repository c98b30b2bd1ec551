// Vehicle families: car, plane, watercraft. +y up, length along z with the nose/bow at +z, width along x.
// Random draws are taken one per statement so that their order never depends on argument evaluation order.
#include "synth/generators.h"

#include <cmath>

namespace sdfkit {

// ------------------------------------------------------------------------------------------------ car
SynthShape make_car(Gen& g) {
  const int kind = g.choose({0.27, 0.18, 0.18, 0.13, 0.12, 0.12});  // sedan, hatchback, suv, pickup, sports, van
  double L = g.u(4.0, 5.0), W = g.u(1.65, 1.95);
  double body_h = g.u(0.45, 0.65), clear = g.u(0.12, 0.22), cabin_h = g.u(0.4, 0.55);
  if (kind == 1) L = g.u(3.5, 4.3);
  if (kind == 2) {
    clear = g.u(0.2, 0.3);
    body_h = g.u(0.6, 0.8);
    cabin_h = g.u(0.5, 0.7);
  }
  if (kind == 4) {
    clear = g.u(0.08, 0.13);
    body_h = g.u(0.4, 0.5);
    cabin_h = g.u(0.3, 0.4);
  }
  if (kind == 5) {
    L = g.u(4.4, 5.2);
    clear = g.u(0.15, 0.22);
    body_h = g.u(0.55, 0.7);
    cabin_h = g.u(0.75, 1.0);
  }
  const Vec3f paint = g.pick(palette::kPaint);
  const Vec3f glass = g.pick(palette::kDark);
  const Vec3f tyre = Vec3f(0.06f, 0.06f, 0.06f);
  const Vec3f chrome = g.pick(palette::kMetal);
  const double wr = g.u(0.3, 0.4);  // wheel radius
  // Lower body: a loft of rounded-rectangle (superellipse) sections from the tail to the nose, the bonnet
  // sloping down towards the nose and the tail slightly lower than the middle.
  {
    const double nose_len = g.u(0.12, 0.25), nose_drop = g.u(0.5, 0.8), tail_drop = g.u(0.7, 0.95);
    const double squareness = g.u(3.0, 6.0);
    const std::vector<double> stations = {0.0, 0.03, 0.1, 0.3, 0.5, 0.7, 1 - nose_len, 1 - nose_len / 2, 0.97, 1.0};
    std::vector<std::vector<Vec3>> rings;
    for (const double st : stations) {
      double top = 1.0;
      if (st < 0.1) top = tail_drop + (1 - tail_drop) * st / 0.1;
      if (st > 1 - nose_len) top = 1 - (1 - nose_drop) * (st - (1 - nose_len)) / nose_len;
      const double edge = std::min(st, 1 - st);
      const double bottom = clear + (edge < 0.03 ? 0.06 * (1 - edge / 0.03) : 0.0);
      const double w = 0.5 * W * (edge < 0.1 ? 0.9 + edge : 1.0);
      const double y0 = bottom, y1 = clear + body_h * top;
      std::vector<Vec3> ring;
      const int M = 20;
      for (int k = 0; k < M; ++k) {
        const double a = 2 * M_PI * k / M;
        const double c = std::cos(a), sn = std::sin(a);
        const double x = w * (c < 0 ? -1 : 1) * std::pow(std::abs(c), 2 / squareness);
        const double y = 0.5 * (y0 + y1) + 0.5 * (y1 - y0) * (sn < 0 ? -1 : 1) * std::pow(std::abs(sn), 2 / squareness);
        ring.emplace_back(x, y, -L / 2 + L * st);
      }
      rings.push_back(ring);
    }
    g.add("body", make_loft(rings), paint);
  }
  // Cabin as a hexahedron of glass, framed by pillars and a roof panel.
  const double ctop = clear + body_h + cabin_h;
  double cz0 = -L * g.u(0.3, 0.42), cz1 = L * g.u(0.0, 0.18);  // cabin base, rear and front
  if (kind == 1 || kind == 2 || kind == 5) cz0 = -L / 2 + g.u(0.1, 0.25);
  if (kind == 5) cz1 = L * g.u(0.2, 0.32);
  if (kind == 3) {
    cz0 = -L * 0.1;
    cz1 = L * 0.15;
  }
  const double rake_f = cabin_h * (kind == 5 ? g.u(0.4, 0.9) : g.u(0.9, 1.8));
  const double rake_r = (kind == 1 || kind == 2 || kind == 5) ? cabin_h * g.u(0.05, 0.3) : cabin_h * g.u(0.6, 1.4);
  const double tz0 = cz0 + rake_r, tz1 = std::max(tz0 + 0.3, cz1 - rake_f);
  const double wb = W / 2 - 0.05, wt = W / 2 - g.u(0.12, 0.25);
  const double ybase = clear + body_h - 0.03;
  std::array<Vec3, 8> c;
  for (int i = 0; i < 8; ++i) {
    const double sx = (i & 1) ? 1 : -1;
    const bool top = i & 2, front = i & 4;
    c[i] = Vec3(sx * (top ? wt : wb) * 0.98, top ? ctop - 0.03 : ybase, top ? (front ? tz1 : tz0) : (front ? cz1 : cz0));
  }
  g.add("glass", make_hexahedron(c), glass);
  // Roof panel.
  {
    std::array<Vec3, 8> r;
    for (int i = 0; i < 8; ++i) {
      const double sx = (i & 1) ? 1 : -1;
      const bool up = i & 2, front = i & 4;
      r[i] = Vec3(sx * (wt + 0.02), ctop - (up ? 0.0 : 0.05), front ? tz1 + 0.02 : tz0 - 0.02);
    }
    g.add("roof", make_hexahedron(r), paint);
  }
  // Pillars along the cabin edges: window openings are the gaps between these bars.
  const double pw = g.u(0.05, 0.1);
  for (const double sx : {-1.0, 1.0}) {
    const Vec3 bf(sx * wb, ybase, cz1), tf(sx * wt, ctop - 0.02, tz1);
    const Vec3 br(sx * wb, ybase, cz0), tr(sx * wt, ctop - 0.02, tz0);
    g.add("a_pillar", make_bar(bf, tf, pw, pw * 0.8, Vec3(sx, 0, 0)), paint);
    g.add("c_pillar", make_bar(br, tr, pw * 1.5, pw * 0.8, Vec3(sx, 0, 0)), paint);
    const double zm = 0.5 * (cz0 + cz1), zt = 0.5 * (tz0 + tz1);
    g.add("b_pillar", make_bar(Vec3(sx * wb, ybase, zm), Vec3(sx * wt, ctop - 0.02, zt), pw, pw * 0.8, Vec3(sx, 0, 0)),
          paint);
    // Side mirror on a short stem.
    const Vec3 mbase(sx * (wb + 0.02), ybase + 0.1, cz1 - 0.1);
    g.add("mirror_stem", make_bar(mbase, mbase + Vec3(sx * 0.12, 0.02, 0), 0.03, 0.02, Vec3::UnitY()), paint);
    g.add("mirror", make_ellipsoid(mbase + Vec3(sx * 0.16, 0.04, -0.01), Vec3(0.05, 0.05, 0.025), Mat3::Identity(), 3),
          paint);
  }
  // Pickup bed walls behind the cabin.
  if (kind == 3) {
    const double t = 0.04, z0 = -L / 2 + 0.05, z1 = cz0 - 0.05, y = clear + body_h;
    const double bh = g.u(0.25, 0.4);
    for (const double sx : {-1.0, 1.0})
      g.add("bed_wall", make_box_part(Vec3(sx * (W / 2 - t / 2), y + bh / 2 - 0.02, 0.5 * (z0 + z1)),
                                      Vec3(t / 2, bh / 2, 0.5 * (z1 - z0))),
            paint);
    g.add("tailgate", make_box_part(Vec3(0, y + bh / 2 - 0.02, z0 + t / 2), Vec3(W / 2, bh / 2, t / 2)), paint);
  }
  // Wheels: torus tyre around a hub disc, axis along x.
  const double wz = L / 2 - g.u(0.6, 0.9), ww = g.u(0.18, 0.28);
  const double rim = wr * g.u(0.55, 0.7);
  for (const double sx : {-1.0, 1.0})
    for (const double sz : {-1.0, 1.0}) {
      const Vec3 wc(sx * (W / 2 - ww * 0.3), wr, sz * wz);
      const double tr = ww * 0.5;
      g.add("tyre", make_torus_part(wc, Vec3::UnitX(), std::max(wr - tr, tr * 1.1), tr, 20, 8), tyre);
      g.add("hub", make_cylinder(wc - Vec3(sx * ww * 0.3, 0, 0), wc + Vec3(sx * ww * 0.45, 0, 0), rim, 14), chrome);
    }
  // Bumpers and lights.
  for (const double sz : {-1.0, 1.0}) {
    g.add("bumper", make_bar(Vec3(-W / 2 + 0.02, clear + 0.1, sz * (L / 2 + 0.02)),
                             Vec3(W / 2 - 0.02, clear + 0.1, sz * (L / 2 + 0.02)), 0.14, 0.1, Vec3::UnitY()),
          g.p(0.5) ? paint : chrome);
    const Vec3f lc = sz > 0 ? Vec3f(0.95f, 0.95f, 0.85f) : Vec3f(0.8f, 0.05f, 0.05f);
    for (const double sx : {-1.0, 1.0})
      g.add(sz > 0 ? "headlight" : "taillight",
            make_ellipsoid(Vec3(sx * (W / 2 - 0.22), clear + body_h * 0.42, sz * (L / 2 - 0.02)),
                           Vec3(0.13, 0.06, 0.05), Mat3::Identity(), 3),
            lc);
  }
  // Extras.
  if (kind == 4 || g.p(0.15)) {  // rear spoiler on two posts
    const double sh = g.u(0.1, 0.25), z = -L / 2 + 0.15;
    const double y = clear + body_h;
    g.add("spoiler", make_box_part(Vec3(0, y + sh, z), Vec3(W / 2 - 0.1, 0.02, 0.12)), paint);
    for (const double sx : {-1.0, 1.0})
      g.add("spoiler_post", make_bar(Vec3(sx * W * 0.3, y - 0.02, z), Vec3(sx * W * 0.3, y + sh, z), 0.04, 0.08,
                                     Vec3::UnitZ()),
            paint);
  }
  if (kind == 2 && g.p(0.6)) {  // roof rails
    for (const double sx : {-1.0, 1.0}) {
      g.add("roof_rail", make_bar(Vec3(sx * wt * 0.85, ctop + 0.06, tz0 + 0.05), Vec3(sx * wt * 0.85, ctop + 0.06, tz1 - 0.05),
                                  0.035, 0.03, Vec3::UnitY()),
            chrome);
      for (const double z : {tz0 + 0.08, tz1 - 0.08})
        g.add("rail_post", make_bar(Vec3(sx * wt * 0.85, ctop - 0.02, z), Vec3(sx * wt * 0.85, ctop + 0.07, z), 0.03, 0.05,
                                    Vec3::UnitZ()),
              chrome);
    }
  }
  if (g.p(0.3))
    g.add("antenna", make_cylinder(Vec3(0, ctop - 0.01, tz0 + 0.1), Vec3(0, ctop + g.u(0.2, 0.5), tz0 - 0.05), 0.005, 6),
          Vec3f(0.1f, 0.1f, 0.1f));
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ plane
namespace {
/// A tapered wing panel: root at `root_le` (leading edge point), extending by `span` along `span_dir`, with
/// chords along -z. Root/tip chords and thicknesses; `sweep` moves the tip back, `rise` moves it along `up`.
Mesh wing_panel(const Vec3& root_le, const Vec3& span_dir, const Vec3& up, double span, double root_chord,
                double tip_chord, double root_t, double tip_t, double sweep, double rise) {
  std::array<Vec3, 8> c;
  for (int i = 0; i < 8; ++i) {
    const bool tip = i & 1, top = i & 2, lead = i & 4;
    const double chord = tip ? tip_chord : root_chord, th = tip ? tip_t : root_t;
    Vec3 p = root_le + (tip ? span : 0.0) * span_dir + (tip ? rise : 0.0) * up - Vec3(0, 0, tip ? sweep : 0.0);
    if (!lead) p -= Vec3(0, 0, chord);
    // Thickest near the leading edge: the leading edge keeps the full thickness, the trailing edge a third.
    const double t = lead ? th : th * 0.35;
    p += (top ? 0.5 : -0.5) * t * up;
    c[i] = p;
  }
  return make_hexahedron(c);
}
}  // namespace

SynthShape make_plane(Gen& g) {
  const int kind = g.choose({0.45, 0.2, 0.2, 0.15});  // airliner, prop plane, fighter, business jet
  const double L = g.u(8.0, 12.0);
  const double R = L * (kind == 0 ? g.u(0.045, 0.065) : g.u(0.035, 0.055));
  const Vec3f body = g.pick(palette::kPaint);
  const Vec3f trim = g.p(0.5) ? body : g.pick(palette::kPaint);
  const Vec3f dark = g.pick(palette::kDark);
  const Vec3f metal = g.pick(palette::kMetal);
  // Fuselage: a tube with a radius profile, the tail swept up.
  {
    const int n = 16;
    const double tail_rise = R * g.u(0.3, 0.9);
    const double nose_len = g.u(0.08, 0.16), tail_len = g.u(0.2, 0.32);
    std::vector<Vec3> path;
    std::vector<double> radii;
    for (int i = 0; i < n; ++i) {
      const double s = static_cast<double>(i) / (n - 1);  // 0 tail .. 1 nose
      double r = R, y = 0;
      if (s < tail_len) {
        const double q = s / tail_len;
        r = R * (0.12 + 0.88 * std::sqrt(q));
        y = tail_rise * (1 - q);
      } else if (s > 1 - nose_len) {
        const double q = (1 - s) / nose_len;
        r = R * (0.08 + 0.92 * std::sqrt(std::max(0.0, 1 - (1 - q) * (1 - q))));
      }
      path.emplace_back(0.0, y, -L / 2 + L * s);
      radii.push_back(r);
    }
    g.add("fuselage", make_tube(path, radii, 16), body);
  }
  // Cockpit windows / canopy.
  if (kind == 2)
    g.add("canopy", make_ellipsoid(Vec3(0, R * 0.75, L * 0.3), Vec3(R * 0.55, R * 0.55, L * 0.09), Mat3::Identity(), 4),
          dark);
  else
    g.add("cockpit_window", make_box_part(Vec3(0, R * 0.45, L * 0.43), Vec3(R * 0.6, R * 0.15, R * 0.4), rot_x(-0.4)),
          dark);
  // Main wings.
  const double span = L * (kind == 2 ? g.u(0.22, 0.32) : g.u(0.38, 0.6));
  const double root_c = L * (kind == 2 ? g.u(0.3, 0.4) : g.u(0.13, 0.22));
  const double tip_c = root_c * (kind == 2 ? g.u(0.1, 0.25) : g.u(0.25, 0.5));
  const double sweep = kind == 1 ? g.u(0.0, 0.1) * span : (kind == 2 ? root_c - tip_c * 0.5 : g.u(0.2, 0.6) * span);
  const double wing_y = R * (kind == 1 ? g.u(-0.6, 0.8) : g.u(-0.6, -0.1));
  const double wing_z = L * g.u(0.0, 0.12) + root_c / 2;
  const double dihedral = span * (kind == 2 ? g.u(-0.05, 0.02) : g.u(0.0, 0.1));
  const double root_t = root_c * g.u(0.08, 0.14);
  const Vec3 le(0.0, wing_y, wing_z);
  const Mesh right = wing_panel(le, Vec3::UnitX(), Vec3::UnitY(), span, root_c, tip_c, root_t, root_t * 0.5, sweep,
                                dihedral);
  const Mat3 mirror = Vec3(-1, 1, 1).asDiagonal();
  g.add("wing", right, body);
  g.add("wing", transformed(right, mirror, Vec3::Zero()), body);
  if (kind == 0 && g.p(0.5)) {  // winglets
    for (const double sx : {-1.0, 1.0}) {
      const Vec3 tip(sx * span, wing_y + dihedral, wing_z - sweep);
      g.add("winglet", wing_panel(tip + Vec3(0, 0, -tip_c * 0.1), Vec3::UnitY(), Vec3(sx, 0, 0), span * 0.12, tip_c * 0.8,
                                  tip_c * 0.4, root_t * 0.4, root_t * 0.3, tip_c * 0.3, 0.0),
            trim);
    }
  }
  // Tail: horizontal stabilisers and one or two fins.
  const double hs = span * g.u(0.28, 0.42), hc = root_c * g.u(0.4, 0.6);
  const double tail_z = -L / 2 + hc + L * 0.02;
  const bool t_tail = kind == 3 && g.p(0.6);
  const double fin_h = R * g.u(1.6, 2.6), fin_c = hc * g.u(1.0, 1.4);
  const double hy = t_tail ? R * 0.5 + fin_h : R * 0.3;
  const Mesh hright = wing_panel(Vec3(0, hy, tail_z + (t_tail ? -hc * 0.3 : 0.0)), Vec3::UnitX(), Vec3::UnitY(), hs, hc,
                                 hc * 0.5, hc * 0.1, hc * 0.05, hc * 0.4, hs * 0.05);
  g.add("stabilizer", hright, trim);
  g.add("stabilizer", transformed(hright, mirror, Vec3::Zero()), trim);
  const int fins = kind == 2 && g.p(0.5) ? 2 : 1;
  for (int f = 0; f < fins; ++f) {
    const double x = fins == 1 ? 0.0 : (f == 0 ? -R * 0.6 : R * 0.6);
    const Vec3 dir = fins == 1 ? Vec3::UnitY() : Vec3(x > 0 ? 0.3 : -0.3, 1, 0).normalized();
    g.add("fin", wing_panel(Vec3(x, R * 0.3, tail_z + fin_c * 0.3), dir, Vec3::UnitX(), fin_h, fin_c, fin_c * 0.5,
                            fin_c * 0.1, fin_c * 0.06, fin_c * 0.7, 0.0),
          trim);
  }
  // Engines.
  if (kind == 0 || kind == 3) {
    const int per_side = kind == 0 && g.p(0.3) ? 2 : 1;
    const double er = R * g.u(0.35, 0.55), el = root_c * g.u(0.6, 0.9);
    for (const double sx : {-1.0, 1.0})
      for (int e = 0; e < per_side; ++e) {
        Vec3 c;
        if (kind == 3) {  // rear fuselage engines
          c = Vec3(sx * (R + er * 1.1), R * 0.4, -L * 0.25);
          g.add("pylon", make_bar(Vec3(0, R * 0.4, -L * 0.25), c, el * 0.5, er * 0.4, Vec3::UnitY()), body);
        } else {
          const double f = per_side == 1 ? 0.35 : (e == 0 ? 0.3 : 0.62);
          const double x = sx * span * f;
          const double zle = wing_z - sweep * f;
          c = Vec3(x, wing_y + dihedral * f - er * 1.3, zle + el * 0.25);
          g.add("pylon", make_bar(c + Vec3(0, er * 0.5, 0), Vec3(x, wing_y + dihedral * f, zle - el * 0.2), el * 0.4,
                                  er * 0.25, Vec3::UnitX()),
                body);
        }
        g.add("engine", make_cone(c - Vec3(0, 0, el / 2), c + Vec3(0, 0, el / 2), er * 0.75, er, 16), metal);
        g.add("engine_inlet", make_torus_part(c + Vec3(0, 0, el / 2), Vec3::UnitZ(), er * 0.85, er * 0.15, 16, 6), metal);
      }
  } else if (kind == 1) {
    // Propellers: on the nose, and sometimes on wing nacelles.
    auto propeller = [&](const Vec3& hub) {
      g.add("spinner", make_cone(hub - Vec3(0, 0, R * 0.2), hub + Vec3(0, 0, R * 0.5), R * 0.3, 0.0, 12), metal);
      const int blades = g.n(2, 4);
      const double bl = R * g.u(1.6, 2.4), phase = g.u(0, M_PI);
      for (int b = 0; b < blades; ++b) {
        const double a = phase + 2 * M_PI * b / blades;
        const Vec3 d(std::cos(a), std::sin(a), 0);
        g.add("blade", make_bar(hub, hub + bl * d, R * 0.22, R * 0.04, Vec3::UnitZ()), dark);
      }
    };
    if (g.p(0.6)) {
      propeller(Vec3(0, 0, L / 2 + R * 0.05));
    } else {
      for (const double sx : {-1.0, 1.0}) {
        const double x = sx * span * 0.3;
        const Vec3 c(x, wing_y + dihedral * 0.3, wing_z - sweep * 0.3 - root_c * 0.2);
        g.add("nacelle", make_cone(c - Vec3(0, 0, root_c * 0.6), c + Vec3(0, 0, root_c * 0.4), R * 0.25, R * 0.4, 14), body);
        propeller(c + Vec3(0, 0, root_c * 0.45));
      }
    }
  }
  // Landing gear.
  if (g.p(0.35)) {
    const double gh = R * g.u(0.8, 1.3), wr2 = R * 0.25;
    std::vector<Vec3> struts = {Vec3(0, -R * 0.7, L * 0.35)};
    for (const double sx : {-1.0, 1.0}) struts.emplace_back(sx * R * 1.2, wing_y - R * 0.2, wing_z - root_c * 0.55);
    for (const Vec3& s : struts) {
      const Vec3 w = s - Vec3(0, gh, 0);
      g.add("gear_strut", make_cylinder(s + Vec3(0, R * 0.3, 0), w, R * 0.05, 8), metal);
      g.add("gear_wheel", make_cylinder(w - Vec3(R * 0.12, 0, 0), w + Vec3(R * 0.12, 0, 0), wr2, 12), dark);
    }
  }
  return g.b.build();
}

// ------------------------------------------------------------------------------------------------ watercraft
SynthShape make_watercraft(Gen& g) {
  const int kind = g.choose({0.3, 0.3, 0.25, 0.15});  // sailboat, motorboat, ship, rowboat/canoe
  double L = g.u(6.0, 14.0);
  double B = L * g.u(0.25, 0.38);  // beam
  double Dh = B * g.u(0.35, 0.6);  // hull depth
  if (kind == 2) {
    L = g.u(20.0, 40.0);
    B = L * g.u(0.12, 0.18);
    Dh = B * g.u(0.5, 0.8);
  } else if (kind == 3) {
    L = g.u(3.0, 5.5);
    B = L * g.u(0.18, 0.3);
    Dh = B * g.u(0.35, 0.5);
  }
  const Vec3f hull_c = g.pick(palette::kPaint);
  const Vec3f deck_c = g.p(0.5) ? g.pick(palette::kWood) : g.pick(palette::kLight);
  const Vec3f dark = g.pick(palette::kDark);
  const Vec3f metal = g.pick(palette::kMetal);
  // Hull: loft of U/V cross-sections from stern (-z) to bow (+z), closed by the deck line.
  const double vee = g.u(0.5, 1.6);             // bottom shape exponent: < 1 V-ish, > 1 U-ish
  const double stern_w = g.u(0.55, 0.95);       // transom width fraction
  const double sheer = Dh * g.u(0.05, 0.3);     // deck rise at the bow
  const double bow_rake = g.u(0.05, 0.2) * L;   // keel rises before the bow
  const double deck_y = Dh;
  std::vector<std::vector<Vec3>> rings;
  const int stations = 12, M = 14;
  for (int i = 0; i < stations; ++i) {
    const double s = static_cast<double>(i) / (stations - 1);  // 0 stern .. 1 bow
    const double z = -L / 2 + L * s;
    double wfrac;
    if (s < 0.5)
      wfrac = stern_w + (1 - stern_w) * std::sin(M_PI * s);
    else
      wfrac = std::max(0.02, std::cos((s - 0.5) / 0.5 * M_PI / 2));
    if (kind == 3) wfrac = std::max(0.02, std::sin(M_PI * std::clamp(s, 0.02, 0.98)));
    const double half_w = 0.5 * B * wfrac;
    const double z_rake = std::clamp((z - (L / 2 - bow_rake)) / bow_rake, 0.0, 1.0);
    const double top = deck_y + sheer * s * s;
    const double depth = std::max(Dh * 0.06, Dh * (1 - 0.85 * z_rake) * (kind == 3 ? 0.9 : 1.0));
    std::vector<Vec3> ring;
    for (int k = 0; k < M; ++k) {
      const double a = M_PI + M_PI * k / (M - 1);  // pi..2pi: port deck edge, keel, starboard deck edge
      const double cx = std::cos(a), sy = std::sin(a);
      const double bottom = std::pow(std::abs(sy), vee);
      ring.emplace_back(half_w * cx, top - depth * bottom, z);
    }
    rings.push_back(ring);
  }
  g.add("hull", make_loft(rings), hull_c);
  // Deck: a thin slab following the hull's middle part.
  const double deck_len = L * (kind == 3 ? 0.0 : g.u(0.5, 0.7));
  if (deck_len > 0)
    g.add("deck", make_box_part(Vec3(0, deck_y + 0.02 * Dh, -L * 0.08), Vec3(B * stern_w * 0.42, 0.03 * Dh, deck_len / 2)),
          deck_c);
  // Railings along both sides: posts and a top rail.
  if (kind != 3 && g.p(0.5)) {
    const double rh = Dh * g.u(0.25, 0.4), z0 = -L * 0.42, z1 = L * 0.25;
    const int posts = 6;
    for (const double sx : {-1.0, 1.0}) {
      const double x = sx * B * stern_w * 0.4;
      g.add("rail", make_cylinder(Vec3(x, deck_y + rh, z0), Vec3(x, deck_y + rh, z1), 0.012 * Dh + 0.01, 6), metal);
      for (int p = 0; p < posts; ++p) {
        const double z = z0 + (z1 - z0) * p / (posts - 1);
        g.add("rail_post", make_cylinder(Vec3(x, deck_y - 0.05 * Dh, z), Vec3(x, deck_y + rh, z), 0.008 * Dh + 0.006, 6),
              metal);
      }
    }
  }
  auto cabin = [&](const Vec3& c, const Vec3& half, bool windows) {
    g.add("cabin", make_rounded_box(c, half, std::min(half.minCoeff() * 0.3, 0.15)), deck_c);
    if (!windows) return;
    // Windows: dark panes framed by mullion bars on the cabin sides and front.
    const int n = std::max(2, static_cast<int>(half.z() / (half.y() * 0.8)));
    for (const double sx : {-1.0, 1.0}) {
      const double x = sx * (half.x() + 0.01);
      g.add("window", make_box_part(c + Vec3(x, half.y() * 0.3, 0), Vec3(0.015, half.y() * 0.3, half.z() * 0.8)), dark);
      for (int i = 0; i <= n; ++i) {
        const double z = -half.z() * 0.8 + 1.6 * half.z() * i / n;
        g.add("mullion", make_box_part(c + Vec3(x + sx * 0.012, half.y() * 0.3, z),
                                       Vec3(0.015, half.y() * 0.32, std::max(0.02, half.z() * 0.03))),
              deck_c);
      }
    }
    g.add("window", make_box_part(c + Vec3(0, half.y() * 0.3, half.z() + 0.01), Vec3(half.x() * 0.8, half.y() * 0.3, 0.015)),
          dark);
  };
  if (kind == 0) {
    // Sailboat: mast, boom, sails as thin tapered slabs, small cabin.
    const double mh = L * g.u(0.9, 1.4), mz = L * g.u(0.0, 0.15);
    const double mr = 0.012 * L;
    g.add("mast", make_cylinder(Vec3(0, deck_y - 0.1, mz), Vec3(0, deck_y + mh, mz), mr, 10), metal);
    const double boom_l = L * g.u(0.3, 0.45), boom_y = deck_y + Dh * 0.6;
    g.add("boom", make_cylinder(Vec3(0, boom_y, mz + mr), Vec3(0, boom_y, mz - boom_l), mr * 0.8, 8), metal);
    if (g.p(0.85)) {
      std::array<Vec3, 8> c;  // main sail: a thin triangle-like slab between mast and boom
      for (int i = 0; i < 8; ++i) {
        const bool aft = i & 1, top = i & 2, side = i & 4;
        const double y = top ? deck_y + mh * 0.95 : boom_y + 0.05;
        const double z = aft ? (top ? mz - 0.03 * L : mz - boom_l) : mz - mr;
        c[i] = Vec3(side ? 0.01 : -0.01, y, z);
      }
      g.add("sail", make_hexahedron(c), Vec3f(0.96f, 0.96f, 0.94f));
      if (g.p(0.6)) {
        std::array<Vec3, 8> j;  // jib towards the bow
        const double bz = L * 0.45;
        for (int i = 0; i < 8; ++i) {
          const bool fwd = i & 1, top = i & 2, side = i & 4;
          const double y = top ? deck_y + mh * 0.8 : deck_y + Dh * 0.3;
          const double z = fwd ? (top ? mz + 0.03 * L : bz) : mz + mr;
          j[i] = Vec3(side ? 0.01 : -0.01, y, z);
        }
        g.add("jib", make_hexahedron(j), Vec3f(0.93f, 0.93f, 0.9f));
      }
    }
    if (g.p(0.7)) cabin(Vec3(0, deck_y + Dh * 0.25, -L * 0.12), Vec3(B * 0.25, Dh * 0.3, L * 0.12), true);
  } else if (kind == 1) {
    // Motorboat: cabin with windshield frame, outboard motor or console.
    const double cl = L * g.u(0.1, 0.2);
    const bool windows = g.p(0.7);
    cabin(Vec3(0, deck_y + Dh * 0.3, L * 0.02), Vec3(B * 0.3, Dh * 0.35, cl), windows);
    if (g.p(0.6)) {
      const Vec3 m(0, deck_y + Dh * 0.1, -L / 2 - 0.05 * L);
      g.add("motor", make_rounded_box(m, Vec3(0.04 * L, 0.08 * L, 0.05 * L), 0.02 * L), dark);
      g.add("motor_leg", make_bar(m, m - Vec3(0, Dh * 1.2, 0), 0.03 * L, 0.02 * L, Vec3::UnitZ()), dark);
    }
    if (g.p(0.5))
      g.add("antenna", make_cylinder(Vec3(0, deck_y + Dh * 0.6, -L * 0.05), Vec3(0, deck_y + Dh * 1.6, -L * 0.08), 0.01, 6),
            metal);
  } else if (kind == 2) {
    // Ship: stacked superstructure decks, funnels, masts, lifeboats.
    const int levels = g.n(1, 3);
    const double sz = g.u(-0.2, 0.1) * L;
    double y = deck_y;
    double len = L * g.u(0.2, 0.35), wid = B * 0.35;
    for (int l = 0; l < levels; ++l) {
      const double h = Dh * g.u(0.35, 0.5);
      cabin(Vec3(0, y + h / 2, sz), Vec3(wid, h / 2, len / 2), true);
      y += h;
      len *= 0.7;
      wid *= 0.85;
    }
    const int funnels = g.n(1, 3);
    for (int f = 0; f < funnels; ++f) {
      const double z = sz - L * 0.05 - f * L * 0.08;
      const double fr = B * 0.08;
      const double fh = Dh * g.u(0.6, 1.0);
      const Vec3f fc = g.pick(palette::kPaint);
      g.add("funnel", make_cone(Vec3(0, y - 0.1, z), Vec3(0, y + fh, z - fr * 0.3), fr, fr * 0.9, 14), fc);
    }
    g.add("mast", make_cylinder(Vec3(0, y - 0.1, sz + L * 0.06), Vec3(0, y + Dh * 1.5, sz + L * 0.06), 0.06, 8), metal);
    g.add("yard", make_cylinder(Vec3(-B * 0.2, y + Dh * 1.2, sz + L * 0.06), Vec3(B * 0.2, y + Dh * 1.2, sz + L * 0.06), 0.04,
                                6),
          metal);
    if (g.p(0.6))
      for (const double sx : {-1.0, 1.0})
        g.add("lifeboat", make_ellipsoid(Vec3(sx * B * 0.4, deck_y + Dh * 0.5, sz - L * 0.02),
                                         Vec3(B * 0.06, B * 0.05, L * 0.05), Mat3::Identity(), 4),
              Vec3f(0.95f, 0.45f, 0.1f));
  } else {
    // Rowboat / canoe: thwart seats, oars.
    const int seats = g.n(1, 3);
    for (int s = 0; s < seats; ++s) {
      const double z = -L * 0.25 + L * 0.5 * (s + 0.5) / seats;
      g.add("thwart", make_box_part(Vec3(0, deck_y + 0.02, z), Vec3(B * 0.45, 0.02, 0.1)), deck_c);
    }
    if (g.p(0.6))
      for (const double sx : {-1.0, 1.0})
        g.add("oar", make_cylinder(Vec3(sx * B * 0.2, deck_y + 0.08, -L * 0.3), Vec3(sx * B * 0.35, deck_y + 0.1, L * 0.2),
                                   0.02, 8),
              g.pick(palette::kWood));
  }
  return g.b.build();
}

}  // namespace sdfkit
