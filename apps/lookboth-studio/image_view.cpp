#include "image_view.h"

#include <wx/dcbuffer.h>
#include <wx/dcmemory.h>
#include <wx/settings.h>

#include <algorithm>

namespace lookboth::studio_app {

ImageView::ImageView(wxWindow* parent, const wxString& placeholder)
    : wxPanel(parent, wxID_ANY), placeholder_(placeholder) {
  SetBackgroundStyle(wxBG_STYLE_PAINT);
  SetMinSize(wxSize(160, 120));
  Bind(wxEVT_PAINT, &ImageView::onPaint, this);
  Bind(wxEVT_SIZE, [this](wxSizeEvent& e) {
    Refresh();
    e.Skip();
  });
}

void ImageView::setImage(const wxImage& image, const wxString& caption) {
  image_ = image.IsOk() ? image.Copy() : wxImage();
  caption_ = caption;
  scaled_ = wxBitmap();
  Refresh();
}

void ImageView::setPlaceholder(const wxString& text) {
  placeholder_ = text;
  Refresh();
}

wxRect ImageView::imageRect() const { return imageRect(GetClientSize()); }

wxRect ImageView::imageRect(const wxSize& area) const {
  if (!image_.IsOk() || area.x <= 0 || area.y <= 0) return wxRect();
  const double scale = std::min(static_cast<double>(area.x) / image_.GetWidth(),
                                static_cast<double>(area.y - 18) / image_.GetHeight());
  const int w = std::max(1, static_cast<int>(image_.GetWidth() * scale));
  const int h = std::max(1, static_cast<int>(image_.GetHeight() * scale));
  return wxRect((area.x - w) / 2, (area.y - 18 - h) / 2, w, h);
}

wxRealPoint ImageView::toImage(const wxPoint& p) const {
  const wxRect r = imageRect();
  if (r.IsEmpty() || !r.Contains(p)) return wxRealPoint(-1, -1);
  return wxRealPoint((p.x - r.x + 0.5) * image_.GetWidth() / r.width - 0.5,
                     (p.y - r.y + 0.5) * image_.GetHeight() / r.height - 0.5);
}

void ImageView::onPaint(wxPaintEvent&) {
  wxAutoBufferedPaintDC dc(this);
  draw(dc, GetClientSize());
}

void ImageView::draw(wxDC& dc, const wxSize& area) {
  dc.SetBackground(wxBrush(wxColour(32, 32, 36)));
  dc.Clear();
  dc.SetFont(GetFont());
  dc.SetTextForeground(wxColour(220, 220, 220));
  if (!image_.IsOk()) {
    const wxSize text = dc.GetMultiLineTextExtent(placeholder_);
    dc.DrawText(placeholder_, (area.x - text.x) / 2, (area.y - text.y) / 2);
    return;
  }
  const wxRect r = imageRect(area);
  if (!scaled_.IsOk() || scaled_for_ != r.GetSize()) {
    scaled_ = wxBitmap(image_.Scale(r.width, r.height, wxIMAGE_QUALITY_BILINEAR));
    scaled_for_ = r.GetSize();
  }
  dc.DrawBitmap(scaled_, r.x, r.y);
  dc.DrawText(caption_, 4, area.y - 17);
}

wxImage ImageView::render(const wxSize& size) {
  const wxSize area = size.x > 0 && size.y > 0 ? size : GetClientSize();
  if (area.x <= 0 || area.y <= 0) return wxImage();
  wxBitmap bitmap(area.x, area.y);
  {
    wxMemoryDC dc(bitmap);
    draw(dc, area);
  }
  return bitmap.ConvertToImage();
}

}  // namespace lookboth::studio_app
