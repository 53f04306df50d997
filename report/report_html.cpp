#include "report/report_html.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <vector>

#include <fmt/format.h>

#include "core/durable_folder.h"
#include "report/svg_plots.h"

namespace pvcap::report {

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

namespace {

using nlohmann::json;

std::string esc(const std::string& s) { return html_escape(s); }

std::string num(const json& v, int decimals = 1) {
  if (v.is_null()) return "&ndash;";
  if (v.is_number_integer() || v.is_number_unsigned()) return fmt::format("{}", v.get<std::int64_t>());
  if (v.is_number()) return fmt::format("{:.{}f}", v.get<double>(), decimals);
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  return esc(v.is_string() ? v.get<std::string>() : v.dump());
}

const char* kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b"};

// The page's head (style) and the session's summary table.
void add_summary(std::string& h, const json& r) {
  const json& session = r.at("session");
  h += "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>pvcap report: " +
       esc(session.value("folder", "")) +
       "</title><style>"
       "body{font-family:system-ui,sans-serif;margin:24px auto;max-width:1100px;padding:0 16px;color:#222;"
       "font-size:15px}h1{font-size:24px}h2{font-size:19px;margin-top:32px;border-bottom:1px solid #ccc}"
       "h3{font-size:15px;margin:16px 0 4px}table{border-collapse:collapse;margin:8px 0}"
       "td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#f3f3f3}"
       "td:first-child,th:first-child,td.t{text-align:left}.ok{color:#1a7f37;font-weight:600}"
       ".bad{color:#c62828;font-weight:600}.code{font-family:monospace;font-size:15px}.note{color:#555;font-size:13px;"
       "margin:2px 0}"
       ".banner{padding:10px 14px;border-radius:6px;margin:12px 0;font-size:16px}"
       ".banner.ok{background:#e6f4ea}.banner.bad{background:#fdecea}.thumbs{display:flex;flex-wrap:wrap;gap:12px}"
       ".thumbs figure{margin:0}.thumbs figcaption{font-size:13px}.plots{display:flex;flex-wrap:wrap;gap:8px}"
       "</style></head><body>";
  h += "<h1>Session report</h1>";
  h += "<table>";
  auto row = [&](const std::string& k, const std::string& v) { h += "<tr><th>" + k + "</th><td>" + v + "</td></tr>"; };
  row("folder", esc(session.value("folder", "")));
  row("rig", esc(session.value("rig", "")) + (session.value("simulated", false) ? " (simulated)" : ""));
  row("started", esc(session.value("started_utc", "")));
  row("ended",
      session.value("ended_cleanly", false)
          ? esc(session.value("end_reason", "")) + fmt::format(" after {:.1f} s", session.value("duration_s", 0.0))
          : "<span class='bad'>did not end cleanly</span> " + esc(session.value("end_reason", "")));
  if (session.contains("participant"))
    row("participant", esc(session["participant"].value("pseudonym", "")) + ", skin tone " +
                           esc(session["participant"].value("skin_tone", "")) + ", hand order " +
                           esc(session["participant"].value("hand_order", "")));
  if (session.contains("conditions"))
    row("conditions", "lighting " + esc(session["conditions"].value("lighting", "")) + ", overlay " +
                          esc(session["conditions"].value("sensor_overlay", "")));
  row("pvcap", esc(session.value("pvcap_version", "")));
  h += "</table>";
}

void add_captured_and_lost(std::string& h, const json& r) {
  std::uint64_t lost = 0;
  bool reconciles = true;
  for (const auto& s : r.at("streams")) {
    reconciles &= s.value("reconciles", false);
    lost += s.value("not_received", std::uint64_t(0)) + s.value("connection_losses", std::uint64_t(0));
    if (s.contains("not_kept"))
      for (const auto& [why, n] : s["not_kept"].items())
        if (why != "subsampled") lost += n.get<std::uint64_t>();
  }
  h += fmt::format("<div class='banner {}'>{}</div>", lost == 0 ? "ok" : "bad",
                   lost == 0 ? "Every frame the devices numbered arrived, and every kept frame is stored."
                             : fmt::format("{} frames were lost or not stored for a reason other than the 15 Hz "
                                           "subsampling: see the table below.",
                                           lost));
  h += "<h2>Captured and lost</h2><table><tr><th>stream</th><th>frames stored</th><th>good</th><th>in video</th>"
       "<th>subsampled</th><th>not kept (other reasons)</th><th>never received</th><th>connection losses</th>"
       "<th>rate (Hz)</th><th>reconciles</th></tr>";
  for (const auto& s : r.at("streams")) {
    std::string other;
    std::uint64_t subsampled = 0;
    if (s.contains("not_kept"))
      for (const auto& [why, n] : s["not_kept"].items()) {
        if (why == "subsampled")
          subsampled = n;
        else
          other += fmt::format("{}{}: {}", other.empty() ? "" : ", ", esc(why), n.get<std::uint64_t>());
      }
    const bool camera = s.value("kind", "") == "camera";
    h += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
        "<td>{:.2f}</td><td class='{}'>{}</td></tr>",
        esc(s.value("name", "")), s.value("frames", 0),
        camera && s["by_status"].contains("good") ? num(s["by_status"]["good"]) : "&ndash;",
        camera ? num(s["in_video"]) : "&ndash;", camera ? fmt::format("{}", subsampled) : "&ndash;",
        other.empty() ? (camera ? "0" : "&ndash;") : other, s.value("not_received", 0), s.value("connection_losses", 0),
        s.value("mean_rate_hz", 0.0), s.value("reconciles", false) ? "ok" : "bad",
        s.value("reconciles", false) ? "yes" : "NO");
  }
  h += "</table>";
  h += reconciles ? "<p class='note'>Counts reconcile with the store: per camera, frames stored = good + incomplete = "
                    "in video + not kept (by reason); never received is the drops table (frames the device numbered "
                    "that never came).</p>"
                  : "<p class='bad'>Counts do not reconcile with the store: run `pvcap verify` on the session.</p>";
}

void add_self_check(std::string& h, const json& r) {
  if (r.contains("self_check")) {
    const json& sc = r["self_check"];
    h += "<h2>Sync self-check</h2>";
    h += fmt::format(
        "<p>Each camera's time offset to the pressure, estimated from the data alone ({} presses found, "
        "{} isolated, {} used). Positive: the camera's frames show an instant earlier than their time "
        "says (a latency not declared in the rig file).</p>",
        sc.value("presses_found", 0), sc.value("presses_isolated", 0), sc.value("presses_used", 0));
    h += "<table><tr><th>camera</th><th>offset (ms)</th><th>&plusmn; (ms, 1 s.e.)</th><th>presses</th><th>verdict"
         "</th></tr>";
    for (const auto& c : sc["cameras"]) {
      const bool ok = c.value("verdict", "") == "ok";
      const bool flagged = ok && std::abs(c["offset_ms"].get<double>()) > 2 + 2 * c["uncertainty_ms"].get<double>();
      h += fmt::format("<tr><td>{}</td><td class='{}'>{}</td><td>{}</td><td>{}</td><td class='t'>{}</td></tr>",
                       esc(c.value("name", "")), flagged ? "bad" : "", num(c["offset_ms"], 2),
                       num(c["uncertainty_ms"], 2), c.value("presses", 0),
                       flagged ? "offset beyond 2 ms: check the rig file's latency_ns for this camera"
                               : esc(c.value("verdict", "")));
    }
    h += "</table><p class='note'>" + esc(sc.value("method", "")) + "</p>";
  }
}

void add_intervals(std::string& h, const json& r) {
  h += "<h2>Frame intervals</h2><p class='note'>Time between consecutive frames of each stream on the session clock; "
       "red lines: frames the device numbered that never arrived.</p>";
  for (const auto& s : r.at("intervals")) {
    Series se{{}, "#1f77b4", s.value("name", "")};
    for (const auto& p : s["series"]) se.points.emplace_back(p[0].get<double>(), p[1].get<double>());
    std::vector<double> marks;
    for (const auto& d : s["drops"]) marks.push_back(d[0].get<double>());
    h += fmt::format("<h3>{}: median {:.2f} ms, p99 {:.2f} ms, max {:.2f} ms, {} never received</h3>",
                     esc(s.value("name", "")), s.value("median_ms", 0.0), s.value("p99_ms", 0.0),
                     s.value("max_ms", 0.0), s.value("not_received", 0));
    const double med = s.value("median_ms", 1.0);
    h += "<div class='plots'>" +
         line_plot({se}, "session time (s)", "interval (ms)", marks, std::make_pair(0.0, std::max(3 * med, 1.0))) +
         bar_plot(s["histogram"], "interval (ms)") + "</div>";
  }
}

void add_clocks(std::string& h, const json& r) {
  h += "<h2>Clock models</h2><p class='note'>Each device's clock against the host's: how its offset moved (drift), "
       "and the 99th percentile of arrival latency above the fitted line (residuals). A reset starts a new segment. "
       "A camera's stamp marks the start of its exposure: its data's instant, the middle of the exposure, is half "
       "the exposure later (less the rig file's declared latency where no latch reads the clock)."
       "</p><table><tr><th>stream</th><th>source</th><th>segments</th><th>resets</th><th>device clock fast by (ppm)"
       "</th>"
       "<th>stamp to data's instant (ms)</th><th>residual p99, median (&micro;s)</th><th>residual p99, max "
       "(&micro;s)</th></tr>";
  for (const auto& c : r.at("clocks"))
    h += fmt::format(
        "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2f}</td><td>{:.2f}</td><td>{:.0f}</td>"
        "<td>{:.0f}</td></tr>",
        esc(c.value("name", "")), esc(c.value("source", "")), c.value("segments", 0), c.value("resets", 0),
        c.value("device_fast_ppm", 0.0), c.value("stamp_to_instant_ms", 0.0), c.value("residual_p99_us_median", 0.0),
        c.value("residual_p99_us_max", 0.0));
  h += "</table>";
  {
    std::vector<Series> offsets, residuals;
    std::size_t k = 0;
    for (const auto& c : r.at("clocks")) {
      Series o{{}, kPalette[k % 6], c.value("name", "")}, res{{}, kPalette[k % 6], c.value("name", "")};
      for (const auto& p : c["series"]) {
        o.points.emplace_back(p["t_s"].get<double>(), p["offset_change_us"].get<double>() / 1e3);
        res.points.emplace_back(p["t_s"].get<double>(), p["residual_p99_us"].get<double>());
      }
      offsets.push_back(std::move(o));
      residuals.push_back(std::move(res));
      ++k;
    }
    h += "<div class='plots'>" + line_plot(offsets, "session time (s)", "offset change (ms)") +
         line_plot(residuals, "session time (s)", "residual p99 (\xC2\xB5s)") + "</div><p class='note'>";
    k = 0;
    for (const auto& c : r.at("clocks"))
      h += fmt::format("<span style='color:{}'>&#9632;</span> {} &nbsp; ", kPalette[k++ % 6], esc(c.value("name", "")));
    h += "</p>";
  }
}

void add_pairing(std::string& h, const json& r) {
  {
    const json& p = r.at("pairing");
    h += "<h2>Pairing</h2>";
    h += fmt::format(
        "<p>{} samples; {} paired with a pressure frame, {} without; {} missing a camera; {} ties (the "
        "pressure frames before and after equally near). |camera &minus; pressure| offset: p50 {:.2f} ms, "
        "p99 {:.2f} ms. Spread of a sample's camera frames: p50 {:.2f} ms, max {:.2f} ms.</p>",
        p.value("samples", 0), p.value("paired", 0), p.value("unpaired", 0), p.value("missing_a_camera", 0),
        p.value("ties", 0), p.value("abs_offset_ms_p50", 0.0), p.value("abs_offset_ms_p99", 0.0),
        p.value("camera_span_ms_p50", 0.0), p.value("camera_span_ms_max", 0.0));
    h += bar_plot(p["offset_histogram_ms"], "pressure frame time minus sample time (ms)");
    if (p.contains("timeline_counts")) {
      h += "<table><tr><th>timeline tally</th><th>count</th></tr>";
      for (const auto& [what, n] : p["timeline_counts"].items())
        h += fmt::format("<tr><td>{}</td><td>{}</td></tr>", esc(what), n.get<std::uint64_t>());
      h += "</table>";
    }
  }
}

void add_protocol(std::string& h, const json& r) {
  const json& session = r.at("session");
  {
    const json& p = r.at("protocol");
    h += "<h2>Protocol</h2>";
    if (p.contains("note")) h += "<p class='note'>" + esc(p["note"].get<std::string>()) + "</p>";
    if (!p["takes"].empty()) {
      h += takes_timeline(p["takes"], session.value("duration_s", 0.0));
      h += "<p class='note'><span style='color:#2ca02c'>&#9632;</span> done <span style='color:#9467bd'>&#9632;"
           "</span> superseded <span style='color:#d62728'>&#9632;</span> bad <span style='color:#ff7f0e'>&#9632;"
           "</span> interrupted</p>";
      if (p.contains("by_force") && !p["by_force"].empty()) {
        h += "<h3>Force by requested level (done takes)</h3><table><tr><th>force level</th><th>takes</th><th>mean "
             "force (N)</th><th>peak force (N)</th></tr>";
        for (const auto& [level, v] : p["by_force"].items())
          h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>", esc(level),
                           num(v.value("takes", json())), num(v.value("mean_newtons", json()), 2),
                           num(v.value("peak_newtons", json()), 2));
        h += "</table>";
      }
      // The lighting columns only where the rig switched lights (docs/lighting.md).
      bool lit = false;
      for (const auto& t : p["takes"]) lit = lit || t.contains("lighting");
      h += fmt::format(
          "<h3>Takes</h3><table><tr><th>sequence</th><th>status</th><th>start (s)</th><th>end (s)</th><th>mean "
          "(N)</th><th>peak (N)</th>{}<th>check</th></tr>",
          lit ? "<th>lighting commanded</th><th>lighting the images saw</th>" : "");
      for (const auto& t : p["takes"]) {
        std::string lighting;
        if (lit && t.contains("lighting")) {
          const json& l = t["lighting"];
          const bool flagged = l.value("flagged", false);
          lighting =
              fmt::format("<td class='code'>{}</td><td class='code'>{}{}</td>", esc(l.value("commanded", "")),
                          flagged ? "<span class='bad'>" : "", esc(l.value("seen", "")) + (flagged ? "</span>" : ""));
          if (flagged) lighting.insert(lighting.size() - 5, " (light " + esc(l.value("lights", "")) + ")");
        } else if (lit) {
          lighting = "<td>&ndash;</td><td>&ndash;</td>";
        }
        std::string check = "&ndash;";
        if (t.contains("check_ok")) {
          std::string problems;
          for (const auto& pr : t.value("check_problems", json::array())) problems += " " + esc(pr.get<std::string>());
          check = t["check_ok"].get<bool>() ? "ok" : "<span class='bad'>problem:" + problems + "</span>";
        }
        h += fmt::format(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2f}</td><td>{:.2f}</td>{}<td>{}</td></tr>",
            esc(t.value("sequence", "")), esc(t.value("status", "")), num(t.value("start_s", json()), 1),
            num(t.value("end_s", json()), 1), t.value("mean_newtons", 0.0), t.value("peak_newtons", 0.0), lighting,
            check);
      }
      h += "</table>";
      if (p.value("lighting_flagged_takes", 0) > 0)
        h += fmt::format(
            "<p class='bad'>{} take(s) were recorded under another lighting than commanded: the images show a light "
            "that did not come on, or one that was on. Redo them (pvcap dataset status lists what is missing).</p>",
            p.value("lighting_flagged_takes", 0));
    }
  }
}

// The light check and every switch of the lights, as the images confirmed it (docs/lighting.md).
void add_lighting(std::string& h, const json& r) {
  if (!r.contains("lighting")) return;
  const json& l = r["lighting"];
  h += "<h2>Lighting</h2>";
  if (l.contains("check")) {
    h += "<h3>Light check (each light on alone at the start)</h3><table><tr><th>light</th><th>seen by the "
         "cameras</th><th>came on after (ms)</th></tr>";
    for (const auto& x : l["check"].value("lights", json::array()))
      h += fmt::format("<tr><td class='code'>{}</td><td>{}</td><td>{}</td></tr>", esc(x.value("light", "")),
                       x.value("seen", false) ? "yes" : "<span class='bad'>no</span>",
                       num(x.value("latency_ms", json()), 0));
    h += "</table>";
    for (const auto& p : l["check"].value("problems", json::array()))
      h += "<p class='bad'>" + esc(p.get<std::string>()) + "</p>";
  }
  h += fmt::format(
      "<h3>Switches</h3><p class='note'>{} switch(es), {} shown late (more than two frames after the "
      "command), {} never shown.</p>",
      l["switches"].size(), l.value("late", 0), l.value("unconfirmed", 0));
  h += "<table><tr><th>at (s)</th><th>from</th><th>to</th><th>the images showed it</th></tr>";
  for (const auto& sw : l["switches"]) {
    std::string seen;
    if (sw.value("confirmed", false))
      seen =
          fmt::format("{}after {} ms ({} frames){}",
                      sw.value("on_time", true) ? "" : "<span class='bad'>late: ", num(sw.value("delay_ms", json()), 0),
                      num(sw.value("frames", json()), 0), sw.value("on_time", true) ? "" : "</span>");
    else
      seen =
          sw.value("superseded", false) ? "switched again before a frame showed it" : "<span class='bad'>never</span>";
    h += fmt::format("<tr><td>{}</td><td class='code'>{}</td><td class='code'>{}</td><td>{}</td></tr>",
                     num(sw.value("at_s", json()), 2), esc(sw.value("from", "")), esc(sw.value("code", "")), seen);
  }
  h += "</table>";
  if (!l.contains("lines")) return;
  h += "<h3>Output lines, frame by frame</h3><p class='note'>Where a camera's chunk data gave its lines' levels: the "
       "frames whose lines were not as the lights were commanded (the first 100 ms after each command left out).</p>"
       "<table><tr><th>camera</th><th>its lights</th><th>frames checked</th><th>lines not as commanded</th></tr>";
  for (const auto& x : l["lines"]) {
    const std::uint64_t bad = x.value("disagreeing", std::uint64_t(0));
    h += fmt::format("<tr><td>{}</td><td class='code'>{}</td><td>{}</td><td>{}</td></tr>", esc(x.value("camera", "")),
                     esc(x.value("lights", "")), x.value("frames_checked", std::uint64_t(0)),
                     bad == 0 ? std::string("0")
                              : fmt::format("<span class='bad'>{} (the first at {} s)</span>", bad,
                                            num(x.value("first_disagreement_s", json()), 2)));
  }
  h += "</table>";
}

void add_calibration(std::string& h, const json& r) {
  h += "<h2>Calibration</h2><table><tr><th>camera</th><th>measured</th><th>RMS (px)</th><th>RMS (mm on the pad)</th>"
       "</tr>";
  for (const auto& c : r.at("calibration")) {
    if (c["measurements"].empty())
      h += "<tr><td>" + esc(c.value("name", "")) + "</td><td colspan='3'>not calibrated</td></tr>";
    for (const auto& m : c["measurements"])
      h += fmt::format("<tr><td>{}</td><td>{} ({})</td><td>{}</td><td>{}</td></tr>", esc(c.value("name", "")),
                       esc(m.value("method", "")), esc(m.value("created_utc", "")), num(m.value("rms_px", json()), 3),
                       num(m.value("rms_mm", json()), 3));
  }
  h += "</table><div class='thumbs'>";
  for (const auto& c : r.at("calibration"))
    if (c.contains("thumbnail"))
      h += fmt::format("<figure><img src='{}' width='480' alt='{}'><figcaption>{}: sample {}{}</figcaption></figure>",
                       c["thumbnail"].get<std::string>(), esc(c.value("name", "")), esc(c.value("name", "")),
                       c.value("thumbnail_sample", 0),
                       c.value("thumbnail_overlay", false) ? ", the pressure overlaid through its calibration"
                                                           : " (no pad calibration: no overlay)");
  h += "</div>";
}

// The cameras' whole state (report/camera_state.h): automatic controls left on, what differs between
// the cameras and from the rig's previous session.
void add_camera_state(std::string& h, const json& r) {
  if (!r.contains("camera_state")) return;
  const json& s = r["camera_state"];
  h += "<h2>Camera state</h2>";
  if (s.value("cameras_with_state", 0) == 0) {
    h += "<p class='note'>not recorded (a session from before pvcap stored each camera's features)</p>";
    return;
  }
  h += fmt::format(
      "<p class='note'>Every readable feature of each camera after pvcap configured it ({} cameras). "
      "Serials, addresses, timestamps, temperatures and counters differ by nature and are not "
      "compared.</p>",
      s.value("cameras_with_state", 0));
  for (const auto& w : s.at("warnings")) h += "<p class='bad'>warning: " + esc(w.get<std::string>()) + "</p>";
  const json& between = s.at("differ_between_cameras");
  if (between.empty())
    h += "<p>The cameras agree on every other feature.</p>";
  else {
    h += "<h3>Differs between the cameras</h3><table><tr><th>feature</th><th>values</th></tr>";
    for (const auto& d : between) {
      std::string values;
      for (const auto& [camera, v] : d.at("values").items())
        values += (values.empty() ? "" : ", ") + esc(camera) + " " + esc(v.get<std::string>());
      h += "<tr><td>" + esc(d.value("feature", "")) + "</td><td class='t'>" + values + "</td></tr>";
    }
    h += "</table>";
  }
  if (s.at("previous_session").is_null())
    h += "<p class='note'>No earlier session of this rig in the same folder to compare with.</p>";
  else if (s.at("differ_from_previous").empty())
    h += "<p>As in the rig's previous session, " + esc(s["previous_session"].get<std::string>()) + ".</p>";
  else {
    h += "<h3>Changed since the rig's previous session, " + esc(s["previous_session"].get<std::string>()) +
         "</h3><table><tr><th>camera</th><th>feature</th><th>then</th><th>now</th></tr>";
    for (const auto& d : s["differ_from_previous"])
      h += "<tr><td>" + esc(d.value("camera", "")) + "</td><td class='t'>" + esc(d.value("feature", "")) +
           "</td><td class='t'>" + esc(d.value("then", "")) + "</td><td class='t'>" + esc(d.value("now", "")) +
           "</td></tr>";
    h += "</table>";
  }
}

// The host's PTP time (report/ptp_time.h), for a session recorded with the rig file's `ptp:`.
void add_ptp_time(std::string& h, const json& r) {
  if (!r.contains("ptp_time")) return;
  const json& p = r["ptp_time"];
  h += "<h2>PTP time</h2>";
  if (p.contains("cameras") && !p["cameras"].empty()) {
    h += "<table><tr><th>camera</th><th>readings</th><th>locked</th><th>largest offset (ns)</th><th>out of lock</th></tr>";
    for (const auto& c : p["cameras"]) {
      std::string out;
      for (const auto& s : c.at("out_of_lock"))
        out += fmt::format("{}{:.1f}-{:.1f} s ({})", out.empty() ? "" : "; ", s.value("from_s", 0.0), s.value("to_s", 0.0),
                           esc(s.value("why", "")));
      h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.0f}</td><td class='{}'>{}</td></tr>",
                       esc(c.value("name", "")), c.value("readings", 0), c.value("locked", 0),
                       c.value("worst_offset_ns", 0.0), out.empty() ? "t" : "t bad", out.empty() ? "never" : out);
    }
    h += "</table>";
  }
  if (!p.contains("readings")) return;  // the host's ptp4l was not read (ptp: host: false)
  std::string gms;
  for (const auto& g : p.at("grandmasters")) gms += (gms.empty() ? "" : ", ") + esc(g.get<std::string>());
  h += fmt::format(
      "<p>The host's PTP time was read {} times (once a second, from ptp4l): in time at {}, following grandmaster "
      "{}; the largest offset from its master {:.0f} ns.</p>",
      p.value("readings", 0), p.value("in_time", 0), gms.empty() ? "none" : gms, p.value("worst_offset_ns", 0.0));
  if (p.at("out_of_time").empty()) {
    h += "<p>Never out of time.</p>";
    return;
  }
  h += fmt::format("<p class='bad'>Out of time for {} s:</p>", p.value("seconds_out_of_time", 0));
  h += "<table><tr><th>from (s)</th><th>to (s)</th><th>seconds</th><th>why</th></tr>";
  for (const auto& s : p["out_of_time"])
    h += fmt::format("<tr><td>{:.1f}</td><td>{:.1f}</td><td>{}</td><td class='t'>{}</td></tr>", s.value("from_s", 0.0),
                     s.value("to_s", 0.0), s.value("seconds", 0), esc(s.value("why", "")));
  h += "</table>";
}

void add_events(std::string& h, const json& r) {
  h += "<h2>Events</h2>";
  if (r.at("events").empty())
    h += "<p class='note'>none</p>";
  else {
    h += "<table><tr><th>time (s)</th><th>kind</th><th>message</th></tr>";
    for (const auto& e : r["events"])
      h += fmt::format("<tr><td>{:.3f}</td><td>{}</td><td class='t'>{}</td></tr>", e.value("t_s", 0.0),
                       esc(e.value("kind", "")), esc(e.value("message", "")));
    h += "</table>";
  }
}

}  // namespace

std::string render_html(const json& r) {
  std::string h;
  add_summary(h, r);
  add_captured_and_lost(h, r);
  add_self_check(h, r);
  add_intervals(h, r);
  add_clocks(h, r);
  add_ptp_time(h, r);
  add_pairing(h, r);
  add_protocol(h, r);
  add_lighting(h, r);
  add_calibration(h, r);
  add_camera_state(h, r);
  add_events(h, r);
  h += "<p class='note'>Made by pvcap report from the session's store; `pvcap report SESSION --json` prints the same "
       "figures.</p></body></html>\n";
  return h;
}

Result<std::filesystem::path> write_html_report(const std::filesystem::path& dir, const ReportOptions& o) {
  auto data = build_report(dir, o);
  if (!data) return data.error();
  const std::filesystem::path path = dir / "report.html";
  // Whole or not at all, and a failure says the disk's own error (ENOSPC, EIO), not a guess at it.
  if (Status s = write_file_atomically(path, render_html(data.value()), Durability::Renamed); !s.ok())
    return Error{fmt::format("could not write the report: {}", s.error().message)};
  return path;
}

}  // namespace pvcap::report
