#include "nets/plot.h"

#include "core/files.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace sdfkit {

std::string format_csv(const std::vector<std::string>& header, const std::vector<std::vector<double>>& rows) {
  std::ostringstream o;
  for (size_t i = 0; i < header.size(); ++i) o << (i ? "," : "") << header[i];
  o << '\n';
  o << std::setprecision(7);
  for (const auto& r : rows) {
    for (size_t i = 0; i < r.size(); ++i) {
      if (i) o << ',';
      if (std::isfinite(r[i])) o << r[i];
    }
    o << '\n';
  }
  return o.str();
}


void write_loss_plot_svg(const std::string& path, const std::vector<std::vector<double>>& rows,
                         const std::vector<std::string>& names, const std::vector<int>& columns,
                         const std::string& title) {
  const double W = 720, H = 420, L = 70, R = 20, T = 40, Bm = 50;
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& r : rows) {
    if (r.empty() || !std::isfinite(r[0])) continue;
    x0 = std::min(x0, r[0]);
    x1 = std::max(x1, r[0]);
    for (int c : columns)
      if (c < static_cast<int>(r.size()) && std::isfinite(r[c]) && r[c] > 0) {
        y0 = std::min(y0, std::log10(r[c]));
        y1 = std::max(y1, std::log10(r[c]));
      }
  }
  if (!(x1 > x0)) x1 = x0 + 1;
  if (!(y1 > y0)) {
    y0 = std::isfinite(y0) && y0 < 1e299 ? y0 - 0.5 : -1;
    y1 = y0 + 1;
  }
  y0 = std::floor(y0 * 4) / 4;
  y1 = std::ceil(y1 * 4) / 4;
  auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
  auto Y = [&](double ly) { return H - Bm - (ly - y0) / (y1 - y0) * (H - T - Bm); };
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
  std::ostringstream o;
  o << std::fixed << std::setprecision(1);
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H << "\" font-family=\"sans-serif\" "
    << "font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << W / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << title << "</text>\n";
  o << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << W - L - R << "\" height=\"" << H - T - Bm
    << "\" fill=\"none\" stroke=\"#444\"/>\n";
  for (double ly = y0; ly <= y1 + 1e-9; ly += 0.25) {
    o << "<line x1=\"" << L << "\" x2=\"" << W - R << "\" y1=\"" << Y(ly) << "\" y2=\"" << Y(ly)
      << "\" stroke=\"#ddd\"/>\n<text x=\"" << L - 6 << "\" y=\"" << Y(ly) + 4 << "\" text-anchor=\"end\">"
      << std::setprecision(3) << std::pow(10.0, ly) << std::setprecision(1) << "</text>\n";
  }
  for (int i = 0; i <= 5; ++i) {
    const double x = x0 + (x1 - x0) * i / 5;
    o << "<text x=\"" << X(x) << "\" y=\"" << H - Bm + 18 << "\" text-anchor=\"middle\">" << std::setprecision(0) << x
      << std::setprecision(1) << "</text>\n";
  }
  o << "<text x=\"" << (L + W - R) / 2 << "\" y=\"" << H - 12 << "\" text-anchor=\"middle\">step</text>\n";
  for (size_t k = 0; k < columns.size(); ++k) {
    const int c = columns[k];
    o << "<polyline fill=\"none\" stroke-width=\"1.5\" stroke=\"" << colours[k % 4] << "\" points=\"";
    for (const auto& r : rows)
      if (c < static_cast<int>(r.size()) && std::isfinite(r[c]) && r[c] > 0 && std::isfinite(r[0]))
        o << X(r[0]) << ',' << Y(std::log10(r[c])) << ' ';
    o << "\"/>\n<text x=\"" << W - R - 8 << "\" y=\"" << T + 16 + 16 * k << "\" text-anchor=\"end\" fill=\""
      << colours[k % 4] << "\">" << (c < static_cast<int>(names.size()) ? names[c] : "") << "</text>\n";
  }
  o << "</svg>\n";
  write_text_atomic(path, o.str());
}

}  // namespace sdfkit
