#include "metrics/report.h"

#include "core/json.h"
#include "metrics/chamfer.h"

#include <cstdio>
#include <sstream>

namespace sdfkit {
namespace {

std::string fmt(const std::optional<double>& v) {
  if (!v) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", *v);
  return buf;
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c == '\n' ? ' ' : c;
  }
  return q + "\"";
}

bool is_disn_f(Protocol p, const std::string& key) { return p == Protocol::kDisn && key.rfind("f_", 0) == 0; }

CategorySummary aggregate(const std::string& name, const std::vector<const ShapeRecord*>& shapes, Protocol p) {
  CategorySummary c;
  c.category = name;
  double seconds = 0;
  for (const ShapeRecord* r : shapes) {
    ++c.total;
    if (r->status == "ok") {
      ++c.ok;
      seconds += r->result.seconds;
    } else if (r->status == "missing") {
      ++c.missing;
    } else {
      ++c.failed;
    }
  }
  c.seconds_per_shape = c.ok > 0 ? seconds / static_cast<double>(c.ok) : 0.0;
  for (const auto& [key, label] : metric_keys(p)) {
    double sum = 0;
    long n = 0;
    for (const ShapeRecord* r : shapes)
      if (r->status == "ok")
        if (const auto v = r->result.get(key)) {
          sum += *v;
          ++n;
        }
    c.values[key] = n > 0 ? std::optional<double>(sum / static_cast<double>(n)) : std::nullopt;
  }
  // DISN: pool P and R over the category, then F.
  for (const auto& [key, label] : metric_keys(p))
    if (is_disn_f(p, key)) {
      const std::string suffix = key.substr(2);
      const auto P = c.values["p_" + suffix], R = c.values["r_" + suffix];
      c.values[key] = P && R ? std::optional<double>(f_from_pr(*P, *R)) : std::nullopt;
    }
  return c;
}

}  // namespace

Summary summarize(const std::vector<ShapeRecord>& records, Protocol protocol) {
  Summary s;
  s.protocol = protocol;
  std::map<std::string, std::vector<const ShapeRecord*>> by_category;
  for (const auto& r : records) by_category[r.category].push_back(&r);
  for (const auto& [name, shapes] : by_category) s.categories.push_back(aggregate(name, shapes, protocol));
  s.mean.category = "mean";
  double seconds = 0;
  long with_seconds = 0;
  for (const auto& c : s.categories) {
    s.mean.total += c.total;
    s.mean.ok += c.ok;
    s.mean.missing += c.missing;
    s.mean.failed += c.failed;
    if (c.ok > 0) {
      seconds += c.seconds_per_shape;
      ++with_seconds;
    }
  }
  s.mean.seconds_per_shape = with_seconds > 0 ? seconds / static_cast<double>(with_seconds) : 0.0;
  for (const auto& [key, label] : metric_keys(protocol)) {
    double sum = 0;
    long n = 0;
    for (const auto& c : s.categories)
      if (const auto& v = c.values.at(key)) {
        sum += *v;
        ++n;
      }
    s.mean.values[key] = n > 0 ? std::optional<double>(sum / static_cast<double>(n)) : std::nullopt;
  }
  return s;
}

std::string per_shape_csv(const std::vector<ShapeRecord>& records, Protocol protocol) {
  std::ostringstream out;
  const auto keys = metric_keys(protocol);
  out << "category,shape,status";
  for (const auto& [key, label] : keys) out << ',' << key;
  out << ",seconds,reason\n";
  for (const auto& r : records) {
    out << csv_field(r.category) << ',' << csv_field(r.shape) << ',' << r.status;
    for (const auto& [key, label] : keys) out << ',' << (r.status == "ok" ? fmt(r.result.get(key)) : "");
    out << ',' << (r.status == "ok" ? fmt(r.result.seconds) : "") << ',' << csv_field(r.reason) << '\n';
  }
  return out.str();
}

std::string markdown_table(const Summary& s) {
  std::ostringstream out;
  std::vector<const CategorySummary*> cols;
  for (const auto& c : s.categories) cols.push_back(&c);
  cols.push_back(&s.mean);
  out << "| " << to_string(s.protocol) << " |";
  for (const auto* c : cols) out << ' ' << c->category << " |";
  out << "\n|---|";
  for (size_t i = 0; i < cols.size(); ++i) out << "---:|";
  out << '\n';
  for (const auto& [key, label] : metric_keys(s.protocol)) {
    out << "| " << label << " |";
    for (const auto* c : cols) {
      const auto& v = c->values.at(key);
      char buf[64] = "-";
      if (v) std::snprintf(buf, sizeof buf, "%.3f", *v);
      out << ' ' << buf << " |";
    }
    out << '\n';
  }
  out << "| shapes scored / total |";
  for (const auto* c : cols) out << ' ' << c->ok << '/' << c->total << " |";
  out << "\n| missing predictions |";
  for (const auto* c : cols) out << ' ' << c->missing << " |";
  out << "\n| failed |";
  for (const auto* c : cols) out << ' ' << c->failed << " |";
  out << "\n| eval seconds / shape |";
  for (const auto* c : cols) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f", c->seconds_per_shape);
    out << ' ' << buf << " |";
  }
  out << '\n';
  return out.str();
}

Json summary_json(const Summary& s, const std::vector<ShapeRecord>& records) {
  auto column = [](const CategorySummary& c) {
    Json values = Json::object();
    for (const auto& [k, v] : c.values) values[k] = v ? Json(*v) : Json(nullptr);
    return Json{{"total", c.total},   {"ok", c.ok}, {"missing", c.missing}, {"failed", c.failed},
                {"seconds_per_shape", c.seconds_per_shape}, {"metrics", values}};
  };
  Json cats = Json::object();
  for (const auto& c : s.categories) cats[c.category] = column(c);
  Json problems = Json::array();
  for (const auto& r : records)
    if (r.status != "ok")
      problems.push_back({{"category", r.category}, {"shape", r.shape}, {"status", r.status}, {"reason", r.reason}});
  return {{"protocol", to_string(s.protocol)}, {"categories", cats}, {"mean", column(s.mean)}, {"problems", problems}};
}

}  // namespace sdfkit
