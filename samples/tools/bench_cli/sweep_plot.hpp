// btflod-bench — the scheduler sweep as CSV and as an SVG plot (two panels against the cache
// size: median frame CPU time, and bytes requested; one line per upload budget and mode).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace btflod::bench {

struct SweepRow {
  uint32_t slots = 0, uploads = 0;
  std::string mode;
  double p50 = 0, p95 = 0, p99 = 0, max = 0, x_read = 0, ops = 0, budget_hits = 0, bytes = 0, visible_missing = 0;
  double noise = 0;  ///< relative spread of p50 over the repetitions
};

inline std::string sweep_csv(const std::vector<SweepRow>& rows) {
  std::string s =
      "slots,uploads_per_frame,mode,frame_cpu_us_p50,frame_cpu_us_p95,frame_cpu_us_p99,frame_cpu_us_max,p50_spread,x_"
      "read_p50,"
      "ops_per_frame,budget_hits,bytes_requested,visible_missing\n";
  char buf[512];
  for (const SweepRow& r : rows) {
    std::snprintf(buf, sizeof buf, "%u,%u,%s,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.4f,%.0f,%.0f,%.0f\n", r.slots, r.uploads,
                  r.mode.c_str(), r.p50, r.p95, r.p99, r.max, r.noise, r.x_read, r.ops, r.budget_hits, r.bytes,
                  r.visible_missing);
    s += buf;
  }
  return s;
}

/// Two panels side by side, x = cache slots on a log2 axis; self-contained SVG text.
inline std::string sweep_svg(const std::vector<SweepRow>& rows, const std::string& title) {
  const double pw = 420, ph = 300, ml = 70, mt = 50, mb = 50, gap = 90;
  const double width = ml + 2 * pw + gap + 40, height = mt + ph + mb + 60;
  std::map<std::string, std::vector<const SweepRow*>> series;
  for (const SweepRow& r : rows) series[r.mode + ", " + std::to_string(r.uploads) + " uploads/frame"].push_back(&r);
  double xmin = 1e300, xmax = -1e300;
  for (const SweepRow& r : rows) xmin = std::min(xmin, std::log2(r.slots)), xmax = std::max(xmax, std::log2(r.slots));
  if (!(xmax > xmin)) xmin -= 1, xmax += 1;
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"};
  std::string safe_title;
  for (const char ch : title)
    safe_title += ch == '<' ? std::string("&lt;") : ch == '&' ? std::string("&amp;") : std::string(1, ch);
  char buf[1024];
  std::string s;
  std::snprintf(buf, sizeof buf,
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" font-family=\"sans-serif\" "
                "font-size=\"12\">\n<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
                "<text x=\"%.0f\" y=\"22\" font-size=\"14\">btflod-bench scheduler sweep: %s</text>\n",
                width, height, ml, safe_title.c_str());
  s += buf;
  struct Panel {
    const char* label;
    double (*get)(const SweepRow&);
  };
  const Panel panels[2] = {{"median frame CPU time (us)", [](const SweepRow& r) { return r.p50; }},
                           {"bytes requested (MiB)", [](const SweepRow& r) { return r.bytes / 1048576.0; }}};
  for (int p = 0; p < 2; ++p) {
    const double x0 = ml + p * (pw + gap), y0 = mt;
    double ymax = 0;
    for (const SweepRow& r : rows) ymax = std::max(ymax, panels[p].get(r));
    if (!(ymax > 0)) ymax = 1;
    ymax *= 1.1;
    auto X = [&](double slots) { return x0 + (std::log2(slots) - xmin) / (xmax - xmin) * pw; };
    auto Y = [&](double v) { return y0 + ph - v / ymax * ph; };
    std::snprintf(buf, sizeof buf,
                  "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"none\" stroke=\"#444\"/>\n", x0,
                  y0, pw, ph);
    s += buf;
    for (int t = 0; t <= 4; ++t) {
      const double v = ymax * t / 4;
      std::snprintf(
          buf, sizeof buf,
          "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/><text x=\"%.1f\" y=\"%.1f\" "
          "text-anchor=\"end\">%.3g</text>\n",
          x0, Y(v), x0 + pw, Y(v), x0 - 6, Y(v) + 4, v);
      s += buf;
    }
    std::vector<uint32_t> xs;
    for (const SweepRow& r : rows) xs.push_back(r.slots);
    std::sort(xs.begin(), xs.end());
    xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
    for (const uint32_t x : xs) {
      std::snprintf(buf, sizeof buf, "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%u</text>\n", X(x),
                    y0 + ph + 18, x);
      s += buf;
    }
    std::snprintf(buf, sizeof buf,
                  "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">cache slots</text>\n<text x=\"%.1f\" y=\"%.1f\" "
                  "text-anchor=\"middle\" font-weight=\"bold\">%s</text>\n",
                  x0 + pw / 2, y0 + ph + 36, x0 + pw / 2, y0 - 8, panels[p].label);
    s += buf;
    int k = 0;
    for (const auto& [name, list] : series) {
      std::vector<const SweepRow*> sorted = list;
      std::sort(sorted.begin(), sorted.end(), [](const SweepRow* a, const SweepRow* b) { return a->slots < b->slots; });
      std::string pts;
      for (const SweepRow* r : sorted) {
        std::snprintf(buf, sizeof buf, "%.1f,%.1f ", X(r->slots), Y(panels[p].get(*r)));
        pts += buf;
      }
      const char* c = colours[k % 8];
      s += "<polyline fill=\"none\" stroke-width=\"2\" stroke=\"" + std::string(c) + "\" points=\"" + pts + "\"/>\n";
      for (const SweepRow* r : sorted) {
        std::snprintf(buf, sizeof buf, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>\n", X(r->slots),
                      Y(panels[p].get(*r)), c);
        s += buf;
      }
      if (p == 0) {
        const double lx = ml + (k % 3) * 250.0, ly = mt + ph + mb + 10 + (k / 3) * 16.0;
        std::snprintf(
            buf, sizeof buf,
            "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" stroke-width=\"2\"/><text x=\"%.1f\" "
            "y=\"%.1f\">%s</text>\n",
            lx, ly, lx + 20, ly, c, lx + 26, ly + 4, name.c_str());
        s += buf;
      }
      ++k;
    }
  }
  s += "</svg>\n";
  return s;
}

}  // namespace btflod::bench
