// `sdfkit bench recon`: seconds per image against reconstruction error for the adaptive and the dense extraction
// at several effective resolutions (65^3, 129^3, 257^3), on prepared test shapes with their GT meshes.
#include "apps/command.h"
#include "bench/timing.h"
#include "core/error.h"
#include "core/files.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "metrics/protocols.h"
#include "nets/dataset.h"
#include "nets/plot.h"
#include "nets/sdf_train.h"
#include "recon/recon.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>

namespace sdfkit::app {
namespace {



std::function<int()> setup_bench_recon(CLI::App& app) {
  struct Opts {
    std::string data, split = "test", model, pose_model, cam = "gt", out;
    std::vector<int> res{65, 129, 257};
    int shapes = 4, dense_max = 257, repeats = 1;
    double safety = 2.0;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  o->model = default_model_path("sdf.ckpt");
  o->pose_model = default_model_path("pose.ckpt");
  app.add_option("--data", o->data, "prepared dataset with views and gt.obj")->required();
  app.add_option("--split", o->split, "split name or list file")->capture_default_str();
  app.add_option("--shapes", o->shapes, "shapes (view 0 of each) to reconstruct")->capture_default_str();
  app.add_option("--model", o->model, "SDF network model")->capture_default_str();
  app.add_option("--pose-model", o->pose_model, "pose network (with --cam est)")->capture_default_str();
  app.add_option("--cam", o->cam, "gt = the view's true camera, est = the pose network's estimate")
      ->capture_default_str();
  app.add_option("--res", o->res, "effective resolutions (grid points per axis), comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--dense-max-res", o->dense_max, "run the dense baseline only up to this resolution")
      ->capture_default_str();
  app.add_option("--safety", o->safety, "safety factor of the adaptive extraction")->capture_default_str();
  app.add_option("--repeats", o->repeats, "timed runs per (shape, setting); the median is reported")
      ->capture_default_str();
  app.add_option("-o,--out", o->out, "also write the table as CSV to OUT.csv and a plot to OUT.svg");
  app.add_flag("--json", o->json, "print JSON instead of the Markdown table");
  return [o] {
    DatasetSettings ds;
    ds.root = o->data;
    ds.split = o->split;
    ds.max_shapes = o->shapes;
    const Dataset data(ds);
    const bool est = o->cam == "est";
    if (!est && o->cam != "gt") throw InvalidInput("--cam " + o->cam + ": use gt or est");
    const auto rec = Reconstructor::load(require_model_path(o->model, "--model"),
                                         est ? require_model_path(o->pose_model, "--pose-model") : std::string());
    ProtocolSettings ps;
    ps.protocol = Protocol::kDisn;
    ps.with_emd = false;
    struct Row {
      int res;
      bool dense;
      std::vector<double> seconds, field_seconds, evals, cd, iou, f1;
    };
    std::vector<Row> rows;
    for (int r : o->res) {
      rows.push_back({r, false, {}, {}, {}, {}, {}, {}});
      if (r <= o->dense_max) rows.push_back({r, true, {}, {}, {}, {}, {}, {}});
    }
    ProgressBar bar("bench recon", static_cast<long>(data.size() * rows.size()));
    long done = 0;
    for (size_t s = 0; s < data.size(); ++s) {
      const Eigen::VectorXf input = data.input(s, 0);
      const Camera truth = data.camera(s, 0);
      const Mesh gt = read_mesh(data.gt_mesh_path(s));
      const Camera cam = est ? rec->estimate_camera(input) : truth;
      for (Row& row : rows) {
        ReconSettings rs;
        rs.resolution = row.res;
        rs.dense = row.dense;
        rs.safety = o->safety;
        rs.preview = false;
        std::vector<double> secs, fsecs;
        ReconResult r;
        for (int k = 0; k < std::max(1, o->repeats); ++k) {
          r = rec->run_input(input, &cam, rs, data.shape(s).id);
          secs.push_back(r.timings.total);
          fsecs.push_back(r.timings.field);
        }
        row.seconds.push_back(median(secs));
        row.field_seconds.push_back(median(fsecs));
        row.evals.push_back(static_cast<double>(r.evaluations));
        const EvalResult e = evaluate(r.mesh, gt, ps);
        row.cd.push_back(e.get("cd").value_or(std::nan("")));
        row.iou.push_back(e.get("iou").value_or(std::nan("")));
        row.f1.push_back(e.get("f_1").value_or(std::nan("")));
        bar.update(++done);
      }
    }
    bar.finish();
    Json j = Json::array();
    std::ostringstream md, csv;
    md << "| resolution | extraction | s/image (median) | field s (median) | evaluations (mean) | CD x1000 | IoU % | "
          "F-score(1%) |\n|---|---|---|---|---|---|---|---|\n";
    csv << "resolution,extraction,seconds,field_seconds,evaluations,cd,iou,f1\n";
    std::vector<std::vector<double>> plot;
    for (const Row& row : rows) {
      const double sec = median(row.seconds), fs = median(row.field_seconds), ev = mean(row.evals);
      const double cd = mean(row.cd), iou = mean(row.iou), f1 = mean(row.f1);
      j.push_back({{"resolution", row.res}, {"extraction", row.dense ? "dense" : "adaptive"}, {"seconds", sec},
                   {"field_seconds", fs}, {"evaluations", ev}, {"cd", cd}, {"iou", iou}, {"f1", f1},
                   {"shapes", row.seconds.size()}});
      char line[256];
      std::snprintf(line, sizeof line, "| %d^3 | %s | %.3f | %.3f | %.0f | %.3f | %.2f | %.2f |\n", row.res,
                    row.dense ? "dense" : "adaptive", sec, fs, ev, cd, iou, f1);
      md << line;
      csv << row.res << ',' << (row.dense ? "dense" : "adaptive") << ',' << sec << ',' << fs << ',' << ev << ','
          << cd << ',' << iou << ',' << f1 << '\n';
      plot.push_back({sec, row.dense ? std::nan("") : cd, row.dense ? cd : std::nan("")});
    }
    std::sort(plot.begin(), plot.end());
    if (!o->out.empty()) {
      write_text_atomic(o->out + ".csv", csv.str());
      write_loss_plot_svg(o->out + ".svg", plot, {"seconds", "CD x1000 adaptive", "CD x1000 dense"}, {1, 2},
                          "recon: CD against seconds per image (x = seconds)");
    }
    if (o->json)
      std::cout << j.dump(2) << '\n';
    else
      std::cout << "bench recon: " << data.size() << " shapes of " << o->data << " (" << o->split << ", view 0), camera "
                << o->cam << ", safety " << o->safety << "\n\n"
                << md.str();
    return int(kOk);
  };
}

SDFKIT_REGISTER_COMMAND("bench recon", "seconds per image against CD/IoU for adaptive vs dense extraction at 65/129/257",
                        setup_bench_recon);

}  // namespace
}  // namespace sdfkit::app
