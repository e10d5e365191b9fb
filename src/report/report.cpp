#include "hapticcal/report/report.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include "hapticcal/core/cancel.hpp"
#include "hapticcal/core/error.hpp"
#include "hapticcal/core/files.hpp"
#include "report/process.hpp"

namespace hapticcal {
namespace {

namespace fs = std::filesystem;

bool gnuplot_available() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string p = path;
  size_t start = 0;
  while (start <= p.size()) {
    const size_t end = p.find(':', start);
    const std::string dir =
        p.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!dir.empty() && fs::exists(fs::path(dir) / "gnuplot")) return true;
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return false;
}

std::string quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) out += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return out + "\"";
}

std::string number(double v) { return fmt::format("{:.6g}", v); }

std::string range(double lo, double hi) {
  return fmt::format("[{}:{}]", std::isnan(lo) ? "*" : number(lo),
                     std::isnan(hi) ? "*" : number(hi));
}

// "lc rgb ... dt ... lw ... pt ..." of a series, as much as it sets.
std::string line_style(const Series& s) {
  std::string out;
  if (!s.color.empty()) out += " lc rgb " + quote(s.color);
  if (s.dash > 0) out += fmt::format(" dt {}", s.dash);
  if (s.width > 0) out += fmt::format(" lw {}", number(s.width));
  const bool points = s.style.find("points") != std::string::npos || s.error >= 0;
  if (s.point > 0 && points) out += fmt::format(" pt {}", s.point);
  return out;
}

// The plot of a 3-D figure (a series with a z column): the axes to one scale
// (`view equal xyz`), the floor at the axis' lower limit, seen from above at an
// angle (FigureSpec::extra may enlarge it: `set view 60, 30, SCALE`).
std::string script_3d(const FigureSpec& f, const std::string& data) {
  std::string s = fmt::format("set zlabel {} noenhanced rotate parallel\n", quote(f.zlabel));
  s += "set view 60, 30\nset view equal xyz\nset ticslevel 0\n";
  if (!std::isnan(f.x_min) || !std::isnan(f.x_max))
    s += fmt::format("set xrange {}\n", range(f.x_min, f.x_max));
  if (!std::isnan(f.y_min) || !std::isnan(f.y_max))
    s += fmt::format("set yrange {}\n", range(f.y_min, f.y_max));
  s += f.extra + "\n";
  std::string plots;
  for (const Series& ser : f.series) {
    const std::string x = ser.x < 0 ? "0" : fmt::format("{}", ser.x + 2);
    plots += fmt::format("{}{} using {}:{}:{} with {}{} {}", plots.empty() ? "" : ", ", quote(data),
                         x, ser.y + 2, ser.z + 2, ser.style, line_style(ser),
                         ser.label.empty() ? "notitle" : "title " + quote(ser.label));
  }
  return s + "splot " + plots + "\n";
}

// The gnuplot commands of one figure for a terminal. `data` names the data file
// relative to the figures folder (gnuplot runs there). The output file is the
// variable `output_var`, defaulting to `output`: write_report sets it to a
// temporary name, a user running the script gets the final one. No title: the
// report's caption is the figure's one title.
std::string script(const FigureSpec& f, const std::string& data, const std::string& terminal,
                   const std::string& output_var, const std::string& output) {
  std::string s = fmt::format(
      "set terminal {}\nset termoption noenhanced\nif (!exists(\"{}\")) {} = {}\nset output {}\n",
      terminal, output_var, output_var, quote(output), output_var);
  s += fmt::format("set xlabel {} noenhanced\nset ylabel {} noenhanced\n", quote(f.xlabel),
                   quote(f.ylabel));
  s += "set datafile separator ','\n";
  if (f.matrix.size() > 0) {
    // Each cell a rectangle (`pixels`): sharp in SVG at any size.
    s += "set view map\nset palette defined (-1 'blue', 0 'white', 1 'red')\nset cbrange [-1:1]\n";
    s += fmt::format("set cblabel {} noenhanced\nset size ratio -1\n", quote(f.cblabel));
    s += fmt::format("set xrange [-0.5:{}]\nset yrange [{}:-0.5]\n", number(f.matrix.cols() - 0.5),
                     number(f.matrix.rows() - 0.5));
    std::string tics;
    for (size_t i = 0; i < f.xtics.size(); ++i)
      tics += fmt::format("{}{} {}", i ? ", " : "", quote(f.xtics[i]), i);
    if (!tics.empty())
      s += fmt::format("set xtics ({}) rotate by 90 right\nset ytics ({})\n", tics, tics);
    s += f.extra + "\n";
    s += fmt::format("plot {} matrix with image pixels notitle\n", quote(data));
    return s;
  }
  s += "set grid\nset key below horizontal noenhanced\n";
  const bool three_d =
      std::any_of(f.series.begin(), f.series.end(), [](const Series& ser) { return ser.z >= 0; });
  if (three_d) return s + script_3d(f, data);
  // Autoscaled axes get a margin so that points on the frame show; never below
  // a fixed lower limit (a quantity that cannot be negative keeps y >= 0).
  const bool y_fixed_low = f.log_y || !std::isnan(f.y_min);
  const bool y_fixed_high = f.log_y || !std::isnan(f.y_max);
  s += fmt::format("set offsets graph 0, graph 0, graph {}, graph {}\n",
                   y_fixed_high ? "0" : "0.05", y_fixed_low ? "0" : "0.05");
  if (f.log_y) s += "set logscale y\nset format y \"%g\"\n";
  if (!std::isnan(f.x_min) || !std::isnan(f.x_max))
    s += fmt::format("set xrange {}\n", range(f.x_min, f.x_max));
  if (!std::isnan(f.y_min) || !std::isnan(f.y_max))
    s += fmt::format("set yrange {}\n", range(f.y_min, f.y_max));
  if (!f.xtics.empty()) {
    // Room under the plot for the vertical labels, the axis label and the key
    // (gnuplot's own margin lets the last two overlap).
    size_t longest = 0;
    for (const std::string& tic : f.xtics) longest = std::max(longest, tic.size());
    s += fmt::format("set xtics rotate by 90 right\nset bmargin {}\n",
                     static_cast<int>(std::ceil(0.6 * static_cast<double>(longest))) + 3);
  }
  s += f.extra + "\n";
  std::string plots;
  for (const Series& ser : f.series) {
    std::string x =
        ser.x < 0 ? "0" : fmt::format("{}", ser.x + 2);  // +1 label column, +1 one-based
    std::string usage = fmt::format("{}:{}", x, ser.y + 2);
    if (ser.error >= 0) usage += fmt::format(":{}", ser.error + 2);
    if (!f.xtics.empty()) usage += ":xtic(1)";
    plots += fmt::format("{}{} using {} with {}{} {}", plots.empty() ? "" : ", ", quote(data),
                         usage, ser.error >= 0 ? "yerrorbars" : ser.style, line_style(ser),
                         ser.label.empty() ? "notitle" : "title " + quote(ser.label));
  }
  s += "plot " + plots + "\n";
  return s;
}

std::string data_text(const FigureSpec& f) {
  std::string out;
  if (f.matrix.size() > 0) {
    for (int r = 0; r < f.matrix.rows(); ++r) {
      for (int c = 0; c < f.matrix.cols(); ++c)
        out += fmt::format("{}{}", c ? "," : "", f.matrix(r, c));
      out += "\n";
    }
    return out;
  }
  const size_t rows = f.columns.empty() ? 0 : f.columns[0].size();
  for (size_t r = 0; r < rows; ++r) {
    out += f.xtics.empty() ? "-" : f.xtics[r];
    for (const auto& col : f.columns) out += fmt::format(",{}", col[r]);
    out += "\n";
  }
  return out;
}

std::string inline_svg(const std::string& svg) {
  const size_t start = svg.find("<svg");
  return start == std::string::npos ? std::string() : svg.substr(start);
}

bool is_numeric_cell(const std::string& cell) {
  if (cell == "-") return true;  // a number that does not apply
  char* end = nullptr;
  std::strtod(cell.c_str(), &end);
  return !cell.empty() && end == cell.c_str() + cell.size();
}

std::string outcome_html(const Outcome& o) {
  std::string html = fmt::format("<section id=\"outcome\"{}>\n<p><b>Status: {}</b></p>\n",
                                 o.usable ? "" : " class=\"unusable\"", markup_escaped(o.status));
  auto list = [&](const std::vector<std::string>& lines, const char* cls) {
    if (lines.empty()) return;
    html += fmt::format("<ul class=\"{}\">\n", cls);
    for (const std::string& line : lines) html += "<li>" + markup_escaped(line) + "</li>\n";
    html += "</ul>\n";
  };
  list(o.headline, "headline");
  list(o.notes, "notes");
  return html + "</section>\n";
}

}  // namespace

void use_log_y(FigureSpec& f, int decades) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (const Series& ser : f.series) {
    if (ser.y < 0 || ser.y >= static_cast<int>(f.columns.size())) continue;
    for (double v : f.columns[ser.y]) {
      if (!(v > 0) || !std::isfinite(v)) continue;
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  f.log_y = true;
  if (!(hi > 0)) {
    f.y_min = f.y_max = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  const double top = std::ceil(std::log10(hi) - 1e-9);
  const double bottom = std::max(std::floor(std::log10(lo) + 1e-9), top - std::max(decades, 1));
  f.y_min = std::pow(10.0, bottom);
  f.y_max = std::pow(10.0, top > bottom ? top : bottom + 1);
}

std::string html_table(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows) {
  std::string out = "<table><thead><tr>";
  for (const std::string& h : header) out += "<th>" + markup_escaped(h) + "</th>";
  out += "</tr></thead><tbody>\n";
  for (const auto& row : rows) {
    out += "<tr>";
    for (const std::string& cell : row) {
      // Numbers align right, text left (a reason, a name).
      out += (is_numeric_cell(cell) ? "<td class=\"n\">" : "<td>") + markup_escaped(cell) + "</td>";
    }
    out += "</tr>\n";
  }
  return out + "</tbody></table>\n";
}

int write_report(const Report& report, const std::string& dir, std::string& note) {
  std::string figures;
  int drawn = 0;
  if (!report.figures.empty() && !gnuplot_available()) {
    note = "figures skipped: gnuplot not found (install Debian's gnuplot-nox)";
  } else if (!report.figures.empty()) {
    const fs::path fig_dir = fs::path(dir) / "figures";
    for (const FigureSpec& f : report.figures) {
      throw_if_cancelled();  // Python's Ctrl-C between figures (core/cancel.hpp)
      const std::string data = f.name + ".csv", gp = f.name + ".gp";
      const fs::path svg = fig_dir / (f.name + ".svg"), png = fig_dir / (f.name + ".png");
      const fs::path log = fig_dir / (gp + ".log");
      // gnuplot writes temporary files, renamed into place once it succeeded:
      // a failure (a full disk) leaves no truncated figure behind.
      const std::string suffix = fmt::format(".tmp-{}", ::getpid());
      const fs::path svg_tmp = svg.string() + suffix, png_tmp = png.string() + suffix;
      write_file_atomically((fig_dir / data).string(), data_text(f));
      write_file_atomically((fig_dir / gp).string(),
                            script(f, data, "svg size 900,480 dynamic font 'sans,11'", "svg_output",
                                   svg.filename().string()) +
                                script(f, data, "pngcairo size 1350,720 font 'sans,11'",
                                       "png_output", png.filename().string()));
      const detail::ProcessStatus run = detail::run_program(
          {"gnuplot", "-e",
           fmt::format("svg_output = {}; png_output = {}", quote(svg_tmp.filename().string()),
                       quote(png_tmp.filename().string())),
           gp},
          log.string(), fig_dir.string());
      std::error_code ec;
      const bool drew = run.ok() && fs::exists(svg_tmp, ec) && fs::exists(png_tmp, ec);
      if (drew) fs::rename(svg_tmp, svg, ec);
      if (drew && !ec) fs::rename(png_tmp, png, ec);
      fs::remove(svg_tmp, ec);
      fs::remove(png_tmp, ec);
      if (fs::exists(log, ec) && fs::file_size(log, ec) == 0) fs::remove(log, ec);
      if (!drew || !fs::exists(svg, ec) || !fs::exists(png, ec)) {
        if (!run.error.empty()) {
          note = fmt::format("figure {} failed: {}", f.name, run.error);
        } else if (fs::exists(log, ec)) {
          // Named within the output folder: `dir` is the staging folder a
          // command writes into, renamed to --out (OutputSet) once it is done.
          note = fmt::format(
              "figure {} failed: gnuplot exit status {}, see figures/{} beside "
              "report.html",
              f.name, run.exit_code, log.filename().string());
        } else {
          note = fmt::format("figure {} failed: gnuplot exit status {}", f.name, run.exit_code);
        }
        continue;
      }
      figures += fmt::format("<figure id=\"{}\">{}<figcaption>{}</figcaption></figure>\n", f.name,
                             inline_svg(read_file(svg.string())), markup_escaped(f.title));
      ++drawn;
    }
  }
  std::string html = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>" +
                     markup_escaped(report.title) +
                     "</title>\n<style>\n"
                     "body{font-family:sans-serif;margin:2em;max-width:1000px;color:#222}\n"
                     "table{border-collapse:collapse;margin:1em 0;font-size:90%}\n"
                     "td,th{border:1px solid #bbb;padding:2px 8px;text-align:left}\n"
                     "th{background:#eee}td.n{text-align:right}\n"
                     "figure{margin:1.5em 0}figure svg{max-width:100%;height:auto}\n"
                     "figcaption{font-style:italic}.note{color:#a40}\n"
                     "#outcome{padding:0.6em 1em;border:2px solid #2a7;background:#efe}\n"
                     "#outcome.unusable{border-color:#c22;background:#fee}\n"
                     "#outcome ul{margin:0.3em 0}\n</style></head><body>\n";
  html += "<h1>" + markup_escaped(report.title) + "</h1>\n";
  html += outcome_html(report.outcome);
  if (!note.empty()) html += "<p class=\"note\">" + markup_escaped(note) + "</p>\n";
  for (const std::string& section : report.sections) html += section;
  html += figures + "</body></html>\n";
  write_file_atomically((fs::path(dir) / "report.html").string(), html);
  return drawn;
}

}  // namespace hapticcal
