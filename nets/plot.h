// Training curves as a small self-contained SVG line plot (no plotting library needed to look at a run).
#pragma once

#include <string>
#include <vector>

namespace sdfkit {

/// Plots the chosen columns of `rows` (x = column 0) as lines, one colour each, on a log10 y axis (non-positive
/// and non-finite values are skipped); `names[c]` labels column c. Written atomically (core/files.h).
void write_loss_plot_svg(const std::string& path, const std::vector<std::vector<double>>& rows,
                         const std::vector<std::string>& names, const std::vector<int>& columns,
                         const std::string& title);

/// A loss curve as CSV text: the header line, then one line per row (7 significant digits; non-finite values are
/// left empty).
std::string format_csv(const std::vector<std::string>& header, const std::vector<std::vector<double>>& rows);

}  // namespace sdfkit
