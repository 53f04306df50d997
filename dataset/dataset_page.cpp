#include "dataset/dataset_page.h"

#include <fmt/format.h>

#include "report/report_html.h"

namespace pvcap::dataset {

using json = nlohmann::json;
using report::html_escape;

namespace {

// A mark beside the colour, so the matrix reads without telling red from green.
const char* cell_mark(const std::string& status) {
  if (status == "done") return "&#10003;";
  if (status == "bad") return "B";
  if (status == "superseded") return "s";
  return "";
}

const char* cell_colour(const std::string& status) {
  if (status == "done") return "#2e7d32";
  if (status == "bad") return "#c62828";
  if (status == "superseded") return "#ef9a00";
  return "#e0e0e0";
}

void matrix(std::string& h, const json& status) {
  const auto actions = status.value("actions", std::vector<std::string>{});
  h += "<h2>Completeness</h2><p class='note'>One row per participant and hand, one column per action "
       "(hover for its name): <span class='k' style='background:#2e7d32'></span> done "
       "<span class='k' style='background:#c62828'></span> bad "
       "<span class='k' style='background:#ef9a00'></span> superseded "
       "<span class='k' style='background:#e0e0e0'></span> missing</p><table class='m'><tr><th>participant</th>"
       "<th>hand</th>";
  for (std::size_t i = 0; i < actions.size(); ++i)
    h += fmt::format("<th title='{}'>{}</th>", html_escape(actions[i]), i + 1);
  h += "<th>to record</th></tr>";
  for (const auto& p : status.value("participants", json::array())) {
    for (const char* hand : {"left", "right"}) {
      h += fmt::format("<tr><td class='t'>{}</td><td class='t'>{}</td>",
                       std::string(hand) == "left" ? html_escape(p.value("participant", "")) : "", hand);
      const json cells = p.value("cells", json::object()).value(hand, json::object());
      for (const auto& a : actions) {
        const std::string s = cells.contains(a) ? cells[a].value("status", "missing") : "";
        h += s.empty() ? "<td></td>"
                       : fmt::format("<td title='{} {}: {}' class='c' style='background:{}'>{}</td>", html_escape(a),
                                     hand, s, cell_colour(s), cell_mark(s));
      }
      std::size_t left = 0;
      for (const auto& r : p.value("remaining", json::array())) left += r.value("hand", "") == hand;
      h += fmt::format("<td>{}</td></tr>", left == 0 ? "<span class='ok'>complete</span>" : std::to_string(left));
    }
  }
  h += "</table><p class='note'>Actions: ";
  for (std::size_t i = 0; i < actions.size(); ++i)
    h += fmt::format("{}{} {}", i ? ", " : "", i + 1, html_escape(actions[i]));
  h += "</p>";
}

}  // namespace

std::string render_dataset_html(const json& status, const std::vector<std::string>& leakage) {
  std::string h =
      "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>Dataset " +
      html_escape(status.value("dataset", "")) +
      "</title><style>body{font-family:system-ui,sans-serif;margin:24px auto;max-width:1200px;padding:0 16px;"
      "color:#222;font-size:15px}h1{font-size:24px}h2{font-size:19px;margin-top:28px;border-bottom:1px solid #ccc}"
      "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
      "th{background:#f3f3f3}td.t,th.t,td:first-child{text-align:left}table.m "
      "td{min-width:18px;height:20px}td.c{text-align:center;color:#fff;font-weight:700}"
      ".k{display:inline-block;width:14px;height:14px;vertical-align:middle;margin:0 2px 0 10px}"
      ".ok{color:#1a7f37;font-weight:600}.bad{color:#c62828;font-weight:600}.note{color:#555;font-size:13px}"
      "</style></head><body>";
  h += "<h1>Dataset " + html_escape(status.value("dataset", "")) + "</h1>";
  const auto participants = status.value("participants", json::array());
  std::size_t complete = 0;
  for (const auto& p : participants) complete += p.value("complete", false);
  h += fmt::format("<p>{} participants ({} complete), {} sessions{}.</p>", participants.size(), complete,
                   status.value("sessions", 0),
                   status.value("withdrawn", 0) ? fmt::format(", {} withdrawn", status.value("withdrawn", 0)) : "");
  matrix(h, status);
  const auto flags = status.value("flags", json::array());
  h += fmt::format("<h2>QA flags ({})</h2>", flags.size());
  if (!leakage.empty()) {
    h += "<p class='bad'>Splits leak:</p><ul>";
    for (const auto& l : leakage) h += "<li>" + html_escape(l) + "</li>";
    h += "</ul>";
  }
  if (flags.empty()) {
    h += "<p class='ok'>None.</p>";
  } else {
    h += "<table><tr><th>participant</th><th class='t'>flag</th><th class='t'>session</th><th class='t'>what</th></tr>";
    for (const auto& f : flags) {
      const std::string folder = f.value("folder", "");
      h += fmt::format("<tr><td>{}</td><td class='t'>{}</td><td class='t'>{}</td><td class='t'>{}</td></tr>",
                       html_escape(f.value("participant", "")), html_escape(f.value("kind", "")),
                       html_escape(folder.substr(folder.find_last_of('/') + 1)), html_escape(f.value("message", "")));
    }
    h += "</table>";
  }
  h += "<h2>Still to record</h2>";
  bool any = false;
  for (const auto& p : participants) {
    const auto remaining = p.value("remaining", json::array());
    if (remaining.empty()) continue;
    any = true;
    h += fmt::format("<h3>{} ({} takes; remaining/{}.yaml)</h3><p>", html_escape(p.value("participant", "")),
                     remaining.size(), html_escape(p.value("participant", "")));
    for (std::size_t i = 0; i < remaining.size(); ++i)
      h += fmt::format("{}{} ({})", i ? ", " : "", html_escape(remaining[i].value("action", "")),
                       html_escape(remaining[i].value("hand", "")));
    h += "</p>";
  }
  if (!any) h += "<p class='ok'>Nothing: every participant is complete.</p>";
  h += "</body></html>\n";
  return h;
}

}  // namespace pvcap::dataset
