#include "app/html_page.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>

#include "app/json_file.hpp"

namespace weldtwin::html {

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

std::string num(double v, int digits) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

std::string base64(const std::vector<uint8_t>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  for (size_t i = 0; i < in.size(); i += 3) {
    const uint32_t n = (static_cast<uint32_t>(in[i]) << 16) | (i + 1 < in.size() ? in[i + 1] << 8 : 0) |
                       (i + 2 < in.size() ? in[i + 2] : 0);
    out += t[(n >> 18) & 63];
    out += t[(n >> 12) & 63];
    out += i + 1 < in.size() ? t[(n >> 6) & 63] : '=';
    out += i + 2 < in.size() ? t[n & 63] : '=';
  }
  return out;
}

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string page_head(const std::string& title) {
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + escape(title) +
         "</title>\n<style>\n"
         "body{font-family:'DejaVu Sans',sans-serif;margin:2em auto;max-width:1100px;color:#222}\n"
         ".verdict{font-size:1.6em;padding:.5em 1em;border-radius:6px;color:#fff}\n"
         ".PASS{background:#2e7d32}.FAIL{background:#c62828}\n"
         "table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{border:1px solid #ccc;padding:.25em "
         ".7em;text-align:left}\n"
         "th{background:#f3f3f3}.bad{color:#c62828;font-weight:bold}\n"
         "figure{display:inline-block;margin:.5em;vertical-align:top}figure img{max-width:520px;border:1px "
         "solid #ddd}\n"
         ".plots figure img{max-width:1000px}figcaption{font-size:.85em;color:#555;max-width:520px}\n"
         "</style></head><body>\n";
}

std::string figure(const std::string& dir, const std::string& file, const std::string& title,
                   const std::string& caption) {
  return "<figure><img alt=\"" + escape(title) + "\" src=\"data:image/png;base64," +
         base64(read_bytes(dir + "/" + file)) + "\"><figcaption><b>" + escape(title) + ".</b> " +
         escape(caption) + "</figcaption></figure>\n";
}

bool gnuplot(const std::string& dir, const std::string& script_name, const std::string& script) {
  const std::string path = dir + "/" + script_name;
  write_text_file(path, script);
  const std::string call = "gnuplot '" + path + "' 2>'" + path + ".log'";
  return std::system(call.c_str()) == 0;
}

}  // namespace weldtwin::html
