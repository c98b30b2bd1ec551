// The report folder (report/report.h): index.html, viewer/ (model-viewer and its licence), items/<k>.jpg (the
// input, shrunk), items/<k>.js (the reconstruction beside its ground truth as a base64 GLB handed to
// sdfkitModel(k, data): a script, because pages opened from the disk may not fetch files), curves/*.svg.
#include "report/report.h"

#include "camera/image.h"
#include "core/error.h"
#include "core/files.h"
#include "core/glb.h"
#include "core/json.h"
#include "core/mesh_io.h"
#include "metrics/protocols.h"
#include "report/decimate.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

namespace sdfkit {
namespace {

namespace fs = std::filesystem;

constexpr const char* kViewerScript = "model-viewer-umd.min.js";
/// The scores shown (disn protocol, docs/eval.md): key, column label, whether larger is better.
struct Score {
  const char* key;
  const char* label;
};
constexpr Score kScores[] = {{"cd", "CD ×1000"}, {"f_1", "F@1% (%)"}, {"iou", "IoU (%)"}};

struct Item {
  std::string name, category, input, mesh, gt;
  std::string error;  ///< why the item failed ("" = it did not)
  std::vector<std::string> warnings;
  std::optional<double> seconds;
  long faces = 0, shown_faces = 0;
  std::optional<double> scores[std::size(kScores)];
  bool image = false, model = false;
};

std::string html_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string base64(const std::string& in) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t v = static_cast<uint8_t>(in[i]) << 16 | static_cast<uint8_t>(in[i + 1]) << 8 |
                       static_cast<uint8_t>(in[i + 2]);
    for (int s = 18; s >= 0; s -= 6) out += table[(v >> s) & 63];
  }
  if (i < in.size()) {
    uint32_t v = static_cast<uint8_t>(in[i]) << 16;
    if (i + 1 < in.size()) v |= static_cast<uint8_t>(in[i + 1]) << 8;
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += i + 1 < in.size() ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

/// A relative path from recon's record: as given when it exists, else from the JSON file's folder.
std::string resolve(const std::string& path, const std::string& base_dir) {
  if (path.empty() || fs::path(path).is_absolute() || fs::exists(path) || base_dir.empty()) return path;
  const fs::path p = fs::path(base_dir) / path;
  return fs::exists(p) ? p.string() : path;
}

/// The category of an item: its name up to the first '_' (car_0021 -> car), else "all".
std::string category_of(const std::string& name) {
  const size_t cut = name.find('_');
  return cut == std::string::npos || cut == 0 ? "all" : name.substr(0, cut);
}

std::string find_gt(const std::string& gt_dir, const std::string& name) {
  if (gt_dir.empty()) return {};
  for (const char* ext : {".obj", ".ply", ".off", ".stl", ".glb", ".gltf"}) {
    const fs::path p = fs::path(gt_dir) / (name + ext);
    if (fs::exists(p)) return p.string();
  }
  return {};
}

/// `image` as RGB on white, its longest side shrunk to at most `side` pixels by area averaging.
Image thumbnail(const Image& image, int side) {
  const Image rgb = to_rgb(image, 1.0f);
  const int longest = std::max(rgb.width, rgb.height);
  if (longest <= side) return rgb;
  const double s = static_cast<double>(longest) / side;
  const int w = std::max(1, static_cast<int>(std::lround(rgb.width / s)));
  const int h = std::max(1, static_cast<int>(std::lround(rgb.height / s)));
  Image out(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int x0 = x * rgb.width / w, x1 = std::max(x0 + 1, (x + 1) * rgb.width / w);
      const int y0 = y * rgb.height / h, y1 = std::max(y0 + 1, (y + 1) * rgb.height / h);
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (int yy = y0; yy < y1; ++yy)
          for (int xx = x0; xx < x1; ++xx) sum += rgb.at(xx, yy, c);
        out.at(x, y, c) = static_cast<float>(sum / ((x1 - x0) * (y1 - y0)));
      }
    }
  return out;
}

Mesh painted(Mesh mesh, float r, float g, float b) {
  if (!mesh.has_colors()) {
    mesh.colors.resize(mesh.V.rows(), 3);
    mesh.colors.rowwise() = Eigen::RowVector3f(r, g, b);
  }
  return mesh;
}

/// The reconstruction (its colours, else light blue) and, to its right, the ground truth (its colours, else grey).
Mesh side_by_side(const Mesh& recon, const Mesh* gt) {
  Mesh out = painted(recon, 0.55f, 0.70f, 0.92f);
  if (gt == nullptr) return out;
  Box3 a, b;
  for (Eigen::Index i = 0; i < recon.V.rows(); ++i) a.extend(recon.V.row(i).transpose());
  for (Eigen::Index i = 0; i < gt->V.rows(); ++i) b.extend(gt->V.row(i).transpose());
  Mesh g = painted(*gt, 0.72f, 0.72f, 0.72f);
  const double gap = 0.15 * std::max(a.extent().maxCoeff(), b.extent().maxCoeff());
  g.V.col(0).array() += a.hi.x() + gap - b.lo.x();
  return concatenate(out, g);
}

void process(Item& it, size_t k, const std::string& dir, const ReportSettings& settings) {
  const std::string stem = "items/" + std::to_string(k);
  try {
    const Image img = read_image(it.input);
    write_image((fs::path(dir) / (stem + ".jpg")).string(), thumbnail(img, settings.thumbnail));
    it.image = true;
  } catch (const Error& e) {
    if (it.error.empty()) it.warnings.push_back(std::string("input image not shown: ") + e.what());
  }
  if (!it.error.empty()) return;
  try {
    const Mesh recon = read_mesh(it.mesh);
    it.faces = recon.num_faces();
    std::optional<Mesh> gt;
    if (!it.gt.empty()) {
      gt = read_mesh(it.gt);
      ProtocolSettings ps;
      ps.with_emd = false;  // exact EMD is the slow part and not among the scores shown
      const EvalResult r = evaluate(recon, *gt, ps);
      for (size_t s = 0; s < std::size(kScores); ++s) it.scores[s] = r.get(kScores[s].key);
    }
    const Mesh shown_recon = decimate_to(recon, settings.max_faces);
    std::optional<Mesh> shown_gt;
    if (gt) shown_gt = decimate_to(*gt, settings.max_faces);
    const Mesh shown = side_by_side(shown_recon, shown_gt ? &*shown_gt : nullptr);
    it.shown_faces = shown.num_faces();
    write_text_atomic((fs::path(dir) / (stem + ".js")).string(),
                      "sdfkitModel(" + std::to_string(k) + ",\"" + base64(encode_glb(shown)) + "\");\n");
    it.model = true;
  } catch (const Error& e) {
    it.error = e.what();
  }
}

unsigned long long folder_bytes(const fs::path& dir) {
  unsigned long long n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) n += e.file_size();
  return n;
}

const char* kStyle = R"(
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222}
table{border-collapse:collapse}td,th{border-bottom:1px solid #ddd;padding:4px 8px;text-align:left;vertical-align:middle}
th.sort{cursor:pointer;user-select:none}th.sort:after{content:" \2195";color:#999}
td.num{text-align:right;font-variant-numeric:tabular-nums}
div.view{width:320px;height:200px;background:#f4f4f4}model-viewer{width:100%;height:100%;--poster-color:#f4f4f4}
model-viewer::part(default-progress-bar){display:none}
img.input{max-width:160px;max-height:160px}
.warn{color:#a60;font-size:12px;max-width:24em}.fail{color:#b00}
#errors{color:#b00;white-space:pre-wrap}
.curves img{max-width:640px;border:1px solid #ddd;margin:4px}
)";

// The page's script: lazy loading (a model's script is added when its row comes near the view), the sort, and a
// record of what happened in the DOM (body's data-items/-requested/-loaded/-failed/-errors/-ready-ms, each
// model-viewer's data-state, #errors) for people and for the browser test (scripts/check_report).
const char* kScript = R"(
(function(){
const body=document.body, errors=[];
function noteError(m){errors.push(String(m));const e=document.getElementById('errors');e.textContent=errors.join('\n');
  e.hidden=false;body.dataset.errors=errors.length;}
window.addEventListener('error',function(e){noteError(e.message||('cannot load '+(e.target&&(e.target.src||e.target.href))));},true);
window.addEventListener('unhandledrejection',function(e){noteError('unhandled rejection: '+e.reason);});
const consoleError=console.error;console.error=function(){noteError(Array.prototype.join.call(arguments,' '));consoleError.apply(console,arguments);};
// A row holds an empty slot (div.view) until it nears the window; then its model-viewer is made and its model's
// script added: 500 viewer elements made up front would cost the page seconds.
const slots=Array.from(document.querySelectorAll('div.view[data-k]')), viewers=[];
function update(){let l=0,f=0;for(const v of viewers){const s=v.dataset.state;if(s==='loaded')l++;if(s==='failed')f++;}
  const r=viewers.length;body.dataset.requested=r;body.dataset.loaded=l;body.dataset.failed=f;
  if(r>0&&l+f===r&&!body.dataset.ready){body.dataset.ready='1';body.dataset.readyMs=Math.round(performance.now());if(location.hash==='#check')check();}}
// #check (scripts/check_report): each loaded model's rendered frame is tested for more than one colour, the first
// model's place is recorded for cropping a screenshot. body's data-ready-ms: milliseconds from the navigation's
// start to every model requested so far (those in view) loaded.
function colours(v,tries){const img=new Image();img.onload=function(){const c=document.createElement('canvas');
    c.width=img.width;c.height=img.height;const g=c.getContext('2d');g.drawImage(img,0,0);
    const d=g.getImageData(0,0,c.width,c.height).data;const seen=new Set();
    for(let i=0;i<d.length&&seen.size<3;i+=4)seen.add(d[i]<<16|d[i+1]<<8|d[i+2]);
    if(seen.size<2&&tries>0)setTimeout(function(){colours(v,tries-1);},250);else v.dataset.colours=seen.size;};
  img.src=v.toDataURL('image/png');}
function check(){for(const v of viewers)if(v.dataset.state==='loaded')colours(v,20);  // a first frame may be pending
  const first=viewers.find(function(v){return v.dataset.state==='loaded';});
  if(first){const b=first.getBoundingClientRect();body.dataset.firstViewer=[b.left,b.top,b.width,b.height].map(Math.round).join(',');}
}
window.sdfkitModel=function(k,b64){const v=document.getElementById('mv'+k);const s=atob(b64);const a=new Uint8Array(s.length);
  for(let i=0;i<s.length;i++)a[i]=s.charCodeAt(i);v.src=URL.createObjectURL(new Blob([a],{type:'model/gltf-binary'}));};
function request(slot){const k=slot.dataset.k,v=document.createElement('model-viewer');
  v.id='mv'+k;v.dataset.k=k;v.dataset.state='requested';v.alt=slot.dataset.name;
  // eager: load as soon as src is set (model-viewer's own lazy rule would wait for the element to be in view)
  for(const [a,x] of [['loading','eager'],['camera-controls',''],['disable-zoom',''],['interaction-prompt','none'],
      ['shadow-intensity','0'],['exposure','1.1'],['camera-orbit','30deg 70deg auto']])v.setAttribute(a,x);
  v.addEventListener('load',function(){v.dataset.state='loaded';update();});
  v.addEventListener('error',function(e){v.dataset.state='failed';noteError('model '+k+': '+(e.detail&&e.detail.type));update();});
  slot.appendChild(v);viewers.push(v);update();
  const s=document.createElement('script');s.src='items/'+k+'.js';
  s.onerror=function(){v.dataset.state='failed';update();};document.head.appendChild(s);}
const io=new IntersectionObserver(function(es){for(const e of es)if(e.isIntersecting){io.unobserve(e.target);request(e.target);}},{rootMargin:'200px'});
for(const v of slots)io.observe(v);
body.dataset.items=document.querySelectorAll('#items tbody tr').length;update();
// Sorting: a click on a column's header sorts by it (again: the other way); empty cells last.
for(const th of document.querySelectorAll('#items th.sort')){th.addEventListener('click',function(){
  const tb=document.querySelector('#items tbody'),col=th.cellIndex,dir=th.dataset.dir==='1'?-1:1;th.dataset.dir=dir;
  const key=function(tr){const c=tr.cells[col];const v=c.dataset.v;return v===undefined||v===''?null:(isNaN(+v)?v:+v);};
  const rows=Array.from(tb.rows);rows.sort(function(a,b){const x=key(a),y=key(b);if(x===null)return y===null?0:1;if(y===null)return -1;
    return (x<y?-1:x>y?1:0)*dir;});for(const r of rows)tb.appendChild(r);});}
})();
)";

}  // namespace

std::string require_viewer(const std::string& viewer_dir) {
  const fs::path script = fs::path(viewer_dir) / kViewerScript;
  if (viewer_dir.empty() || !fs::is_regular_file(script))
    throw InvalidInput("the report's 3D viewer is missing (" +
                       (viewer_dir.empty() ? std::string("no viewer folder") : script.string()) +
                       "): run scripts/vendor_viewer and reinstall, or set SDFKIT_VIEWER_DIR");
  return script.string();
}

ReportSummary write_report(const Json& records_in, const std::string& base_dir, const std::string& dir,
                           const ReportSettings& settings) {
  const std::string viewer = require_viewer(settings.viewer_dir);
  if (settings.max_faces < 1) throw InvalidInput("--max-faces must be at least 1");
  if (settings.thumbnail < 8) throw InvalidInput("--thumbnail must be at least 8 pixels");
  const Json records = records_in.is_array() ? records_in : Json::array({records_in});
  std::vector<Item> items;
  for (const Json& r : records) {
    if (!r.is_object() || !r.contains("input") || !r["input"].is_string())
      throw InvalidInput("not a record of sdfkit recon --json (an object with \"input\" expected)");
    Item it;
    it.input = resolve(r["input"].get<std::string>(), base_dir);
    it.name = fs::path(it.input).stem().string();
    it.category = category_of(it.name);
    if (r.contains("error")) it.error = r["error"].is_string() ? r["error"].get<std::string>() : r["error"].dump();
    if (r.contains("mesh") && r["mesh"].is_string()) it.mesh = resolve(r["mesh"].get<std::string>(), base_dir);
    else if (it.error.empty()) it.error = "the record names no mesh";
    if (r.contains("warnings") && r["warnings"].is_array())
      for (const Json& w : r["warnings"]) it.warnings.push_back(w.is_string() ? w.get<std::string>() : w.dump());
    if (r.contains("seconds") && r["seconds"].is_object() && r["seconds"].contains("total") &&
        r["seconds"]["total"].is_number())
      it.seconds = r["seconds"]["total"].get<double>();
    it.gt = find_gt(settings.gt_dir, it.name);
    items.push_back(std::move(it));
  }

  fs::create_directories(dir);
  const fs::path index = fs::path(dir) / "index.html";
  if (fs::exists(index)) {  // an earlier report of ours: its items and curves go, so that none is left over
    std::ifstream in(index);
    std::string head(4096, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    if (head.find("<meta name=\"generator\" content=\"sdfkit report\">") != std::string::npos) {
      fs::remove_all(fs::path(dir) / "items");
      fs::remove_all(fs::path(dir) / "curves");
    }
  }
  fs::create_directories(fs::path(dir) / "items");
  fs::create_directories(fs::path(dir) / "viewer");
  fs::copy_file(viewer, fs::path(dir) / "viewer" / kViewerScript, fs::copy_options::overwrite_existing);
  const fs::path licence = fs::path(settings.viewer_dir) / "LICENSE";
  if (fs::exists(licence))
    fs::copy_file(licence, fs::path(dir) / "viewer" / "LICENSE", fs::copy_options::overwrite_existing);
  std::vector<std::string> curve_files;
  for (const std::string& c : settings.curves) {
    if (!fs::is_regular_file(c)) throw InvalidInput(c + ": no such loss curve file");
    fs::create_directories(fs::path(dir) / "curves");
    const std::string name = std::to_string(curve_files.size()) + "_" + fs::path(c).filename().string();
    fs::copy_file(c, fs::path(dir) / "curves" / name, fs::copy_options::overwrite_existing);
    curve_files.push_back(name);
  }

  tbb::parallel_for(size_t(0), items.size(), [&](size_t k) { process(items[k], k, dir, settings); });

  ReportSummary sum;
  sum.items = static_cast<long>(items.size());
  for (const Item& it : items) {
    if (!it.error.empty()) {
      ++sum.failed;
      std::cerr << "sdfkit: error: " << it.name << ": " << it.error << '\n';
    }
    if (it.scores[0]) ++sum.scored;
  }

  // Means per category (and over all), over the items that have the number.
  struct Means {
    long n = 0, failed = 0;
    double total[std::size(kScores) + 1] = {};
    long count[std::size(kScores) + 1] = {};
  };
  std::map<std::string, Means> means;
  for (const Item& it : items)
    for (const std::string& cat : {it.category, std::string("\x7f" "all")}) {
      Means& m = means[cat];
      ++m.n;
      if (!it.error.empty()) ++m.failed;
      for (size_t s = 0; s < std::size(kScores); ++s)
        if (it.scores[s]) m.total[s] += *it.scores[s], ++m.count[s];
      if (it.seconds) m.total[std::size(kScores)] += *it.seconds, ++m.count[std::size(kScores)];
    }

  std::ostringstream h;
  h << "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
    << "<meta name=\"generator\" content=\"sdfkit report\">\n<title>" << html_escape(settings.title) << "</title>\n"
    << "<style>" << kStyle << "</style>\n<script src=\"viewer/" << kViewerScript << "\"></script>\n</head>\n<body>\n"
    << "<h1>" << html_escape(settings.title) << "</h1>\n<p>" << sum.items << " items, " << sum.failed << " failed"
    << (settings.gt_dir.empty() ? std::string(", no ground truth given")
                                : ", " + std::to_string(sum.scored) + " scored against their ground truth "
                                  "(protocol disn, docs/eval.md)")
    << ". Each 3D view shows the reconstruction (left) and its ground truth (right, when known), decimated to at "
       "most "
    << settings.max_faces << " faces each; drag to turn. Click a column's header to sort.</p>\n"
    << "<pre id=\"errors\" hidden></pre>\n";

  h << "<h2>Means per category</h2>\n<table id=\"means\"><thead><tr><th>category</th><th>items</th><th>failed</th>";
  for (const Score& s : kScores) h << "<th>" << s.label << "</th>";
  h << "<th>seconds</th></tr></thead><tbody>\n";
  for (const auto& [cat, m] : means) {
    h << "<tr><td>" << html_escape(cat == "\x7f" "all" ? std::string("all") : cat) << "</td><td class=\"num\">" << m.n
      << "</td><td class=\"num\">" << m.failed << "</td>";
    for (size_t s = 0; s <= std::size(kScores); ++s)
      h << "<td class=\"num\">" << (m.count[s] > 0 ? fixed(m.total[s] / m.count[s], 2) : "")
        << "</td>";
    h << "</tr>\n";
  }
  h << "</tbody></table>\n";

  if (!curve_files.empty()) {
    h << "<h2>Loss curves</h2>\n<div class=\"curves\">";
    for (const std::string& c : curve_files)
      h << "<img src=\"curves/" << html_escape(c) << "\" alt=\"" << html_escape(c) << "\">";
    h << "</div>\n";
  }

  h << "<h2>Items</h2>\n<table id=\"items\"><thead><tr><th class=\"sort\">#</th><th class=\"sort\">name</th>"
    << "<th class=\"sort\">category</th><th>input</th><th>reconstruction | ground truth</th>";
  for (const Score& s : kScores) h << "<th class=\"sort\">" << s.label << "</th>";
  h << "<th class=\"sort\">seconds</th><th class=\"sort\">faces</th><th class=\"sort\">warnings</th></tr></thead>"
    << "<tbody>\n";
  for (size_t k = 0; k < items.size(); ++k) {
    const Item& it = items[k];
    h << "<tr><td class=\"num\" data-v=\"" << k << "\">" << k + 1 << "</td><td data-v=\"" << html_escape(it.name)
      << "\" title=\"" << html_escape(it.input) << "\">" << html_escape(it.name) << "</td><td data-v=\""
      << html_escape(it.category) << "\">" << html_escape(it.category) << "</td><td>";
    if (it.image) h << "<img class=\"input\" loading=\"lazy\" src=\"items/" << k << ".jpg\" alt=\"input\">";
    h << "</td><td>";
    if (it.model)
      h << "<div class=\"view\" data-k=\"" << k << "\" data-name=\"" << html_escape(it.name) << "\"></div>";
    else
      h << "<span class=\"fail\">failed: " << html_escape(it.error) << "</span>";
    h << "</td>";
    for (size_t s = 0; s < std::size(kScores); ++s)
      h << "<td class=\"num\" data-v=\"" << (it.scores[s] ? fixed(*it.scores[s], 6) : "") << "\">"
        << (it.scores[s] ? fixed(*it.scores[s], 2) : "") << "</td>";
    h << "<td class=\"num\" data-v=\"" << (it.seconds ? fixed(*it.seconds, 6) : "") << "\">"
      << (it.seconds ? fixed(*it.seconds, 2) : "") << "</td><td class=\"num\" data-v=\"" << it.faces << "\">"
      << it.faces << "</td><td class=\"warn\" data-v=\"" << it.warnings.size() << "\">";
    for (size_t w = 0; w < it.warnings.size(); ++w) h << (w ? "<br>" : "") << html_escape(it.warnings[w]);
    h << "</td></tr>\n";
  }
  h << "</tbody></table>\n<p>3D viewer: <a href=\"viewer/LICENSE\">@google/model-viewer</a> (Apache-2.0), "
       "copied into this folder.</p>\n<script>"
    << kScript << "</script>\n</body></html>\n";
  write_text_atomic(index.string(), h.str());

  sum.bytes = folder_bytes(dir);
  sum.first_view_bytes = fs::file_size(index) + fs::file_size(fs::path(dir) / "viewer" / kViewerScript);
  for (size_t k = 0; k < items.size(); ++k)
    if (items[k].image) sum.first_view_bytes += fs::file_size(fs::path(dir) / "items" / (std::to_string(k) + ".jpg"));
  return sum;
}

}  // namespace sdfkit
