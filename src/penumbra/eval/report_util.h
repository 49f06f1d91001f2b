// Small helpers for self-contained reports: base64, in-memory PNG, HTML/XML escaping and
// number formatting shared by the comparison page and the SVG plots.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/image.h"

namespace penumbra {

// RFC 4648 base64 with padding.
std::string base64_encode(const void* data, size_t size);
inline std::string base64_encode(std::string_view s) { return base64_encode(s.data(), s.size()); }

// "data:image/png;base64,..." of encode_png() (core/image.h).
std::string png_data_uri(const Image& image, bool linear = false);

// A CSV field (RFC 4180): quoted, with quotes doubled, when it holds a comma, quote or newline.
std::string csv_field(const std::string& s);
// A number for CSV: the shortest text that reads back exactly; "" for NaN, "inf", "-inf".
std::string csv_number(double v);

// Escapes & < > " ' for HTML/XML text and attribute values.
std::string xml_escape(std::string_view s);

// `v` with `digits` significant digits, in fixed notation for 1e-4 <= |v| < 1e15 and
// scientific otherwise; "0" for 0, "inf", "-inf", "nan".
std::string format_significant(double v, int digits = 3);
// A sample count, possibly interpolated: whole from 100 on, else 3 significant digits without
// trailing zeros ("4", "63.2", "1.5", "1024").
std::string format_light_samples(double v);
// 12345678 -> "12,345,678".
std::string format_grouped(uint64_t v);
// Bytes as "512 B", "1.50 KiB", "3.25 MiB", "1.00 GiB".
std::string format_bytes(uint64_t bytes);

}  // namespace penumbra
