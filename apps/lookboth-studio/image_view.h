// A panel that shows one image scaled to fit (aspect kept), with a caption.
// It draws what it is given; the pictures come from the libraries.
#pragma once

#include <wx/bitmap.h>
#include <wx/image.h>
#include <wx/panel.h>

#include <string>

namespace lookboth::studio_app {

class ImageView : public wxPanel {
 public:
  explicit ImageView(wxWindow* parent, const wxString& placeholder);
  /// Shows `image` (copied); an invalid image shows the placeholder text.
  void setImage(const wxImage& image, const wxString& caption = wxString());
  void setPlaceholder(const wxString& text);
  /// Maps a position in the panel to image pixel coordinates (-1,-1 outside).
  wxRealPoint toImage(const wxPoint& panel_point) const;
  /// What the panel shows, drawn off screen at `size` (default: the panel's
  /// size), whether or not it is on screen (a hidden tab, for screenshots).
  wxImage render(const wxSize& size = wxSize());

 private:
  void onPaint(wxPaintEvent& event);
  wxRect imageRect() const;
  wxRect imageRect(const wxSize& area) const;
  void draw(wxDC& dc, const wxSize& area);

  wxImage image_;
  wxBitmap scaled_;
  wxSize scaled_for_;
  wxString caption_;
  wxString placeholder_;
};

}  // namespace lookboth::studio_app
