// The target page as PDF and PNG (cairo) and SVG (written here: every length in mm).
#include <cairo-pdf.h>
#include <cairo.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "print/target_sheet.h"

namespace omni::print {
namespace {

cairo_status_t Append(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

// Draws the page in mm (the caller has scaled the context from its units).
void Draw(cairo_t* cr, const TargetPage& page) {
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
  // One path, one fill: separate fills would leave hairline seams between touching cells.
  for (const RectMm& r : page.black) cairo_rectangle(cr, r.x, r.y, r.width, r.height);
  for (const RectMm& r : page.scale_bar) cairo_rectangle(cr, r.x, r.y, r.width, r.height);
  cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
  cairo_fill(cr);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, page.text_size_mm);
  for (size_t i = 0; i < page.text.size(); ++i) {
    cairo_move_to(cr, page.text_x_mm, page.text_y_mm + 1.6 * page.text_size_mm * i);
    cairo_show_text(cr, page.text[i].c_str());
  }
}

void Check(cairo_status_t status, const char* what) {
  if (status != CAIRO_STATUS_SUCCESS) {
    throw std::runtime_error(std::string(what) + ": " + cairo_status_to_string(status));
  }
}

std::string Xml(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&') out += "&amp;";
    else if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace

std::string PdfBytes(const TargetPage& page) {
  std::string bytes;
  constexpr double kPointsPerMm = 72.0 / 25.4;
  cairo_surface_t* surface = cairo_pdf_surface_create_for_stream(
      Append, &bytes, page.width_mm * kPointsPerMm, page.height_mm * kPointsPerMm);
  cairo_t* cr = cairo_create(surface);
  cairo_scale(cr, kPointsPerMm, kPointsPerMm);
  Draw(cr, page);
  cairo_show_page(cr);
  const cairo_status_t status = cairo_status(cr);
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t finished = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  Check(status, "PDF drawing");
  Check(finished, "PDF");
  return bytes;
}

std::string PngBytes(const TargetPage& page, double dpi) {
  const double px_per_mm = dpi / 25.4;
  const int w = static_cast<int>(std::lround(page.width_mm * px_per_mm));
  const int h = static_cast<int>(std::lround(page.height_mm * px_per_mm));
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h);
  cairo_t* cr = cairo_create(surface);
  cairo_scale(cr, px_per_mm, px_per_mm);
  Draw(cr, page);
  const cairo_status_t status = cairo_status(cr);
  cairo_destroy(cr);
  std::string bytes;
  const cairo_status_t written = cairo_surface_write_to_png_stream(surface, Append, &bytes);
  cairo_surface_destroy(surface);
  Check(status, "PNG drawing");
  Check(written, "PNG");
  // The pHYs chunk (pixels per metre, unit 1) after IHDR (8 signature + 25 bytes), so that
  // viewers and printers know the dpi.
  const uint32_t ppm = static_cast<uint32_t>(std::lround(dpi / 0.0254));
  std::string chunk = "pHYs";
  for (int k = 0; k < 2; ++k) {
    for (int b = 3; b >= 0; --b) chunk.push_back(static_cast<char>((ppm >> (8 * b)) & 0xff));
  }
  chunk.push_back(1);
  const uint32_t crc = static_cast<uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(chunk.data()), static_cast<uInt>(chunk.size())));
  std::string out = bytes.substr(0, 33);
  out += std::string("\0\0\0\x09", 4) + chunk;
  for (int b = 3; b >= 0; --b) out.push_back(static_cast<char>((crc >> (8 * b)) & 0xff));
  out += bytes.substr(33);
  return out;
}

std::string SvgText(const TargetPage& page) {
  std::string d;
  auto add = [&](const RectMm& r) {
    d += "M" + Num(r.x) + " " + Num(r.y) + "h" + Num(r.width) + "v" + Num(r.height) + "h" +
         Num(-r.width) + "z";
  };
  for (const RectMm& r : page.black) add(r);
  for (const RectMm& r : page.scale_bar) add(r);
  std::string svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                    "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Num(page.width_mm) +
                    "mm\" height=\"" + Num(page.height_mm) + "mm\" viewBox=\"0 0 " +
                    Num(page.width_mm) + " " + Num(page.height_mm) + "\">\n"
                    "<!-- lengths in mm; print at 100% -->\n"
                    "<rect x=\"0\" y=\"0\" width=\"" + Num(page.width_mm) + "\" height=\"" +
                    Num(page.height_mm) + "\" fill=\"#fff\"/>\n"
                    "<path fill=\"#000\" d=\"" + d + "\"/>\n";
  for (size_t i = 0; i < page.text.size(); ++i) {
    svg += "<text x=\"" + Num(page.text_x_mm) + "\" y=\"" +
           Num(page.text_y_mm + 1.6 * page.text_size_mm * i) + "\" font-family=\"sans-serif\" "
           "font-size=\"" + Num(page.text_size_mm) + "\">" + Xml(page.text[i]) + "</text>\n";
  }
  return svg + "</svg>\n";
}

}  // namespace omni::print
