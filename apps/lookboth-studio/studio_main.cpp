// lookboth-studio: the desktop app for calibration technicians. Usage:
//   lookboth-studio [dataset] [--simulate small] [--run-all | --run-until look_down]
//                   [--select cam03] [--frame N] [--overlay before|after|both]
//                   [--export-registration dir] [--align-floor dir] [--check-against dir]
//                   [--export-formats colmap,ros=dir] [--export-report report.html]
//                   [--screenshot out.png] [--exit]
// The options let tests and demos drive the same code paths a click uses.
#include <wx/app.h>
#include <wx/cmdline.h>
#include <wx/config.h>
#include <wx/image.h>
#include <wx/intl.h>
#include <wx/log.h>

#include <clocale>

#include "main_frame.h"

namespace lookboth::studio_app {

class StudioApp : public wxApp {
 public:
  bool OnInit() override {
    // Numbers are read and written with a decimal point whatever the locale.
    wxSetlocale(LC_NUMERIC, "C");
    std::setlocale(LC_NUMERIC, "C");
    SetAppName("lookboth-studio");
    SetVendorName("lookboth");
    wxInitAllImageHandlers();
    if (!wxApp::OnInit()) return false;
    actions_.on_close = [this](int status) { exit_status_ = status; };
    frame_ = new MainFrame(actions_);
    frame_->Show();
    SetTopWindow(frame_);
    return true;
  }

  int OnExit() override {
    delete wxConfigBase::Set(nullptr);
    return wxApp::OnExit();
  }

  int OnRun() override {
    const int status = wxApp::OnRun();
    return status != 0 ? status : exit_status_;
  }

  void OnInitCmdLine(wxCmdLineParser& parser) override {
    wxApp::OnInitCmdLine(parser);
    parser.AddParam("dataset (.rawlog or folder) to open", wxCMD_LINE_VAL_STRING,
                    wxCMD_LINE_PARAM_OPTIONAL);
    parser.AddOption("", "simulate", "simulate a built-in scenario (small, paper...) and open it");
    parser.AddSwitch("", "detections-only", "with --simulate: detections instead of images");
    parser.AddOption("", "simulate-out", "with --simulate: the .rawlog to write");
    parser.AddOption("", "duration", "with --simulate: only the first SECONDS",
                     wxCMD_LINE_VAL_DOUBLE);
    parser.AddSwitch("", "run-all", "run the whole pipeline once the dataset is open");
    parser.AddOption("", "run-until",
                     "run the steps one by one up to this one (detect, odometry, associate, "
                     "motion_calibration, look_down, look_up... as configured)");
    parser.AddOption("", "trajectory",
                     "visual (fisheye odometry) or metric (the dataset's odometry)");
    parser.AddOption("", "select", "select this camera");
    parser.AddOption("", "frame", "show this fisheye frame (0-based)", wxCMD_LINE_VAL_NUMBER);
    parser.AddOption("", "calibration",
                     "LABEL=FILE: load this camera's calibration into the dataset first "
                     "(repeatable)",
                     wxCMD_LINE_VAL_STRING, wxCMD_LINE_PARAM_MULTIPLE);
    parser.AddOption("", "overlay", "fisheye overlay: both (default), before or after");
    parser.AddOption("", "export-registration", "write the registration files into this folder");
    parser.AddOption("", "align-floor",
                     "write the registration in its floor frame into this folder");
    parser.AddOption("", "check-against",
                     "check the registration against the one on record in this folder (which "
                     "cameras moved)");
    parser.AddOption("", "update-record",
                     "RECORD[=OUT]: once the pipeline has run, update the registration on record "
                     "in RECORD with this drive, written to OUT (default: beside the "
                     "registration, '_updated')");
    parser.AddOption("", "export-formats",
                     "FORMATS=DIR: export for other systems (colmap, json, opencv, ros, mrpt, "
                     "all) into this folder");
    parser.AddOption("", "export-report",
                     "write the HTML report (a .html file, or report.html in this folder)");
    parser.AddOption("", "screenshot", "save a PNG of the main window when done");
    parser.AddSwitch("", "exit", "quit when done (exit status 1 if a job failed)");
  }

  bool OnCmdLineParsed(wxCmdLineParser& parser) override {
    if (!wxApp::OnCmdLineParsed(parser)) return false;
    if (parser.GetParamCount() > 0) actions_.open = parser.GetParam(0).ToStdString();
    wxString text;
    if (parser.Found("simulate", &text)) actions_.simulate = text.ToStdString();
    actions_.detections_only = parser.Found("detections-only");
    if (parser.Found("simulate-out", &text)) actions_.simulate_out = text.ToStdString();
    double duration = 0;
    if (parser.Found("duration", &duration)) actions_.duration_s = duration;
    actions_.run_all = parser.Found("run-all");
    if (parser.Found("run-until", &text)) actions_.run_until = text.ToStdString();
    for (const wxCmdLineArg& arg : parser.GetArguments()) {
      if (arg.GetKind() != wxCMD_LINE_OPTION || arg.GetLongName() != "calibration") continue;
      const std::string value = arg.GetStrVal().ToStdString();
      const size_t eq = value.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == value.size()) {
        wxLogError("--calibration: expected LABEL=FILE, got '%s'", arg.GetStrVal());
        return false;
      }
      actions_.calibrations.emplace_back(value.substr(0, eq), value.substr(eq + 1));
    }
    if (parser.Found("overlay", &text)) {
      actions_.overlay = text.ToStdString();
      if (actions_.overlay != "both" && actions_.overlay != "before" &&
          actions_.overlay != "after") {
        wxLogError("--overlay: expected 'both', 'before' or 'after', got '%s'", text);
        return false;
      }
    }
    if (parser.Found("export-registration", &text))
      actions_.export_registration = text.ToStdString();
    if (parser.Found("align-floor", &text)) actions_.align_floor = text.ToStdString();
    if (parser.Found("check-against", &text)) actions_.check_against = text.ToStdString();
    if (parser.Found("update-record", &text)) {
      const std::string value = text.ToStdString();
      const auto equals = value.find('=');
      actions_.update_record = value.substr(0, equals);
      actions_.update_out = equals == std::string::npos ? "" : value.substr(equals + 1);
    }
    if (parser.Found("export-formats", &text)) {
      const std::string value = text.ToStdString();
      const auto equals = value.find('=');
      actions_.export_formats = value.substr(0, equals);
      actions_.export_formats_dir = equals == std::string::npos ? "" : value.substr(equals + 1);
    }
    if (parser.Found("export-report", &text)) actions_.export_report = text.ToStdString();
    if (parser.Found("trajectory", &text)) {
      actions_.trajectory = text.ToStdString();
      if (actions_.trajectory != "visual" && actions_.trajectory != "metric") {
        wxLogError("--trajectory: expected 'visual' or 'metric', got '%s'", text);
        return false;
      }
    }
    if (parser.Found("select", &text)) actions_.select = text.ToStdString();
    long frame = -1;
    if (parser.Found("frame", &frame)) actions_.frame = static_cast<int>(frame);
    if (parser.Found("screenshot", &text)) actions_.screenshot = text.ToStdString();
    actions_.exit = parser.Found("exit");
    return true;
  }

 private:
  StartupActions actions_;
  MainFrame* frame_ = nullptr;
  int exit_status_ = 0;
};

}  // namespace lookboth::studio_app

wxIMPLEMENT_APP(lookboth::studio_app::StudioApp);
