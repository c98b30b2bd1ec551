#include "bench/recon_bench.h"

#include "bench/text.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "metrics/protocols.h"
#include "nets/plot.h"
#include "recon/recon.h"
#include "train/dataset.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sdfkit {
namespace {

const char* extraction_name(const ReconBenchRow& row) { return row.dense ? "dense" : "adaptive"; }

/// The per-row summary every output shares: medians of the times, means of the rest.
struct RowSummary {
  double sec, fs, ev, cd, iou, f1;
  explicit RowSummary(const ReconBenchRow& row)
      : sec(median(row.seconds)),
        fs(median(row.field_seconds)),
        ev(mean(row.evaluations)),
        cd(mean(row.cd)),
        iou(mean(row.iou)),
        f1(mean(row.f1)) {}
};

}  // namespace

ReconBenchResult run_recon_bench(const ReconBenchSettings& settings,
                                 const std::function<void(long done, long total)>& on_progress) {
  DatasetSettings ds;
  ds.root = settings.data;
  ds.split = settings.split;
  ds.max_shapes = settings.shapes;
  const Dataset data(ds);
  const bool est = settings.cam == "est";
  if (!est && settings.cam != "gt") throw InvalidInput("--cam " + settings.cam + ": use gt or est");
  const auto rec = Reconstructor::load(settings.model, est ? settings.pose_model : std::string());
  ProtocolSettings ps;
  ps.protocol = Protocol::kDisn;
  ps.with_emd = false;
  ReconBenchResult result;
  result.data = settings.data;
  result.split = settings.split;
  result.cam = settings.cam;
  {
    ReconSettings rs;
    rs.safety = settings.safety;
    result.safety = rec->extraction_safety(rs);  // the model's default when none was set
  }
  result.shapes = data.size();
  std::vector<ReconBenchRow>& rows = result.rows;
  for (int r : settings.resolutions) {
    rows.push_back({r, false, {}, {}, {}, {}, {}, {}});
    if (r <= settings.dense_max) rows.push_back({r, true, {}, {}, {}, {}, {}, {}});
  }
  const long total = static_cast<long>(data.size() * rows.size());
  long done = 0;
  if (on_progress) on_progress(done, total);
  for (size_t s = 0; s < data.size(); ++s) {
    const Eigen::VectorXf input = data.input(s, 0);
    const Camera truth = data.camera(s, 0);
    const Mesh gt = read_mesh(data.gt_mesh_path(s));
    const Camera cam = est ? rec->estimate_camera(input) : truth;
    for (ReconBenchRow& row : rows) {
      ReconSettings rs;
      rs.resolution = row.resolution;
      rs.dense = row.dense;
      rs.safety = settings.safety;
      rs.preview = false;
      std::vector<double> secs, fsecs;
      ReconResult r;
      for (int k = 0; k < std::max(1, settings.repeats); ++k) {
        r = rec->run_input(input, &cam, rs, data.shape(s).id);
        secs.push_back(r.timings.total);
        fsecs.push_back(r.timings.field);
      }
      row.seconds.push_back(median(secs));
      row.field_seconds.push_back(median(fsecs));
      row.evaluations.push_back(static_cast<double>(r.evaluations));
      const EvalResult e = evaluate(r.mesh, gt, ps);
      row.cd.push_back(e.get("cd").value_or(std::nan("")));
      row.iou.push_back(e.get("iou").value_or(std::nan("")));
      row.f1.push_back(e.get("f_1").value_or(std::nan("")));
      if (on_progress) on_progress(++done, total);
    }
  }
  return result;
}

std::string recon_bench_text(const ReconBenchResult& result) {
  std::ostringstream md;
  md << "bench recon: " << result.shapes << " shapes of " << result.data << " (" << result.split
     << ", view 0), camera " << result.cam << ", safety " << result.safety << "\n\n";
  md << "| resolution | extraction | s/image (median) | field s (median) | evaluations (mean) | CD x1000 | IoU % | "
        "F-score(1%) |\n|---|---|---|---|---|---|---|---|\n";
  for (const ReconBenchRow& row : result.rows) {
    const RowSummary m(row);
    md << detail::bench_printf("| %d^3 | %s | %.3f | %.3f | %.0f | %.3f | %.2f | %.2f |\n", row.resolution,
                               extraction_name(row), m.sec, m.fs, m.ev, m.cd, m.iou, m.f1);
  }
  return md.str();
}

Json recon_bench_json(const ReconBenchResult& result) {
  Json j = Json::array();
  for (const ReconBenchRow& row : result.rows) {
    const RowSummary m(row);
    j.push_back({{"resolution", row.resolution}, {"extraction", extraction_name(row)}, {"seconds", m.sec},
                 {"field_seconds", m.fs}, {"evaluations", m.ev}, {"cd", m.cd}, {"iou", m.iou}, {"f1", m.f1},
                 {"shapes", row.seconds.size()}});
  }
  return j;
}

std::string recon_bench_csv(const ReconBenchResult& result) {
  std::ostringstream csv;
  csv << "resolution,extraction,seconds,field_seconds,evaluations,cd,iou,f1\n";
  for (const ReconBenchRow& row : result.rows) {
    const RowSummary m(row);
    csv << row.resolution << ',' << extraction_name(row) << ',' << m.sec << ',' << m.fs << ',' << m.ev << ','
        << m.cd << ',' << m.iou << ',' << m.f1 << '\n';
  }
  return csv.str();
}

void write_recon_bench_files(const ReconBenchResult& result, const std::string& out) {
  std::vector<std::vector<double>> plot;
  for (const ReconBenchRow& row : result.rows) {
    const RowSummary m(row);
    plot.push_back({m.sec, row.dense ? std::nan("") : m.cd, row.dense ? m.cd : std::nan("")});
  }
  std::sort(plot.begin(), plot.end());
  write_text_atomic(out + ".csv", recon_bench_csv(result));
  write_loss_plot_svg(out + ".svg", plot, {"seconds", "CD x1000 adaptive", "CD x1000 dense"}, {1, 2},
                      "recon: CD against seconds per image (x = seconds)");
}

}  // namespace sdfkit
