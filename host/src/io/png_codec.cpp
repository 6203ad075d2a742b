// SPDX-License-Identifier: Apache-2.0
// libpng reports errors by longjmp. Every libpng call that can fail runs inside one of the small
// functions below that hold the setjmp and no C++ object with a destructor, so that a jump skips
// nothing; the C++ side then throws with the message the error callback kept.
#include "io/png_codec.hpp"

#include "io/checked_output.hpp"

#include <terracl/error.hpp>

#include <png.h>

#include <cstdio>

namespace terracl::io::png {
namespace {

constexpr bool kLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

struct Context {
  char message[256] = "";
  CheckedImageFile* file = nullptr;
};

void on_error(png_structp p, png_const_charp msg) {
  auto* c = static_cast<Context*>(png_get_error_ptr(p));
  std::snprintf(c->message, sizeof c->message, "%s", msg ? msg : "libpng error");
  png_longjmp(p, 1);
}

void on_warning(png_structp, png_const_charp) {}

void on_write(png_structp p, png_bytep data, size_t size) {
  auto* c = static_cast<Context*>(png_get_io_ptr(p));
  if (!c->file->write(data, size)) png_error(p, "write failed");
}

void on_flush(png_structp) {}

bool decode_header(png_structp p, png_infop info, FILE* f, Header* h) {
  if (setjmp(png_jmpbuf(p))) return false;
  png_init_io(p, f);
  png_read_info(p, info);
  const int color = png_get_color_type(p, info);
  const int depth = png_get_bit_depth(p, info);
  if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(p);
  if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(p);
  if (png_get_valid(p, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(p);
  if (depth == 16 && kLittleEndian) png_set_swap(p);
  png_set_interlace_handling(p);
  png_read_update_info(p, info);
  h->width = int(png_get_image_width(p, info));
  h->height = int(png_get_image_height(p, info));
  h->channels = png_get_channels(p, info);
  h->bit_depth = png_get_bit_depth(p, info);
  return true;
}

bool decode_rows(png_structp p, png_bytepp rows) {
  if (setjmp(png_jmpbuf(p))) return false;
  png_read_image(p, rows);  // the pixels; chunks after them (png_read_end) add nothing we use
  return true;
}

bool encode_header(png_structp p, png_infop info, Context* c, const Header* h, png_textp text, int n_text,
                   bool linear) {
  if (setjmp(png_jmpbuf(p))) return false;
  static const int kColor[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                               PNG_COLOR_TYPE_RGB_ALPHA};
  png_set_write_fn(p, c, on_write, on_flush);
  png_set_IHDR(p, info, png_uint_32(h->width), png_uint_32(h->height), h->bit_depth, kColor[h->channels - 1],
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (linear) png_set_gAMA(p, info, 1.0);
  if (n_text > 0) png_set_text(p, info, text, n_text);
  png_write_info(p, info);
  if (h->bit_depth == 16 && kLittleEndian) png_set_swap(p);
  return true;
}

bool encode_rows(png_structp p, png_bytepp rows, int n) {
  if (setjmp(png_jmpbuf(p))) return false;
  png_write_rows(p, rows, png_uint_32(n));
  return true;
}

bool encode_end(png_structp p, png_infop info) {
  if (setjmp(png_jmpbuf(p))) return false;
  png_write_end(p, info);
  return true;
}

// A PNG keyword is 1-79 printable Latin-1 characters without leading, trailing or double spaces.
std::string keyword(const std::string& key) {
  std::string k;
  for (unsigned char ch : key) {
    const bool printable = (ch >= 32 && ch <= 126) || ch >= 161;
    if (ch == ' ' && (k.empty() || k.back() == ' ')) continue;
    k += printable ? char(ch) : '_';
  }
  while (!k.empty() && k.back() == ' ') k.pop_back();
  if (k.size() > 79) k.resize(79);
  return k.empty() ? "comment" : k;
}

bool ascii(const std::string& s) {
  for (unsigned char ch : s)
    if (ch >= 0x80) return false;
  return true;
}

}  // namespace

Pixels read(const std::string& path, const std::function<void(const Header&)>& check, const char* stage) {
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) fail(stage, "{}: cannot open: {}", path, std::strerror(errno));
  std::unique_ptr<FILE, int (*)(FILE*)> closer(f, std::fclose);
  Context ctx;
  png_structp p = png_create_read_struct(PNG_LIBPNG_VER_STRING, &ctx, on_error, on_warning);
  png_infop info = p ? png_create_info_struct(p) : nullptr;
  struct Release {
    png_structp* p;
    png_infop* info;
    ~Release() { png_destroy_read_struct(p, info, nullptr); }
  } release{&p, &info};
  if (!p || !info) fail(stage, "{}: libpng could not start (out of memory)", path);
  Pixels px;
  if (!decode_header(p, info, f, &px.header)) fail(stage, "{}: not a PNG libpng can read ({})", path, ctx.message);
  const Header& h = px.header;
  if (h.width <= 0 || h.height <= 0 || h.channels < 1 || h.channels > 4 || (h.bit_depth != 8 && h.bit_depth != 16))
    fail(stage, "{}: unsupported PNG layout ({} x {}, {} channels of {} bits)", path, h.width, h.height, h.channels,
         h.bit_depth);
  if (check) check(h);
  const size_t stride = size_t(h.width) * size_t(h.channels) * size_t(h.bit_depth / 8);
  px.bytes.resize(stride * size_t(h.height));
  std::vector<png_bytep> rows(size_t(h.height));
  for (size_t y = 0; y < rows.size(); ++y) rows[y] = px.bytes.data() + y * stride;
  if (!decode_rows(p, rows.data())) fail(stage, "{}: reading pixels failed: {}", path, ctx.message);
  return px;
}

struct Writer::Impl {
  Context ctx;
  png_structp p = nullptr;
  png_infop info = nullptr;
  Header header;
  size_t stride = 0;
  int next_row = 0;
  const char* stage = "io";
  ~Impl() { png_destroy_write_struct(&p, &info); }
  [[noreturn]] void failed() {
    ctx.file->check(stage);  // a write error's errno says more than libpng's message
    fail(stage, "cannot write {}: {}", output_name(ctx.file->tmp()), ctx.message);
  }
};

Writer::Writer(CheckedImageFile& file, int width, int height, int channels, int bit_depth, const TextChunks& text,
               bool linear, const char* stage)
    : m(std::make_unique<Impl>()) {
  if (width <= 0 || height <= 0 || channels < 1 || channels > 4 || (bit_depth != 8 && bit_depth != 16))
    fail(stage, "cannot write {}: a PNG of {} x {}, {} channels of {} bits", output_name(file.tmp()), width, height,
         channels, bit_depth);
  m->ctx.file = &file;
  m->stage = stage;
  m->header = {width, height, channels, bit_depth};
  m->stride = size_t(width) * size_t(channels) * size_t(bit_depth / 8);
  m->p = png_create_write_struct(PNG_LIBPNG_VER_STRING, &m->ctx, on_error, on_warning);
  m->info = m->p ? png_create_info_struct(m->p) : nullptr;
  if (!m->p || !m->info) fail(stage, "cannot write {}: libpng could not start", output_name(file.tmp()));
  // png_set_text copies the strings, so they need only live through encode_header.
  std::vector<std::string> keys, values;
  keys.reserve(text.size());
  values.reserve(text.size());
  std::vector<png_text> chunks(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    keys.push_back(keyword(text[i].first));
    values.push_back(text[i].second);
    png_text& t = chunks[i];
    t = png_text{};
    t.key = keys.back().data();
    t.text = values.back().data();
    if (ascii(values.back())) {
      t.compression = PNG_TEXT_COMPRESSION_NONE;
      t.text_length = values.back().size();
    } else {
      t.compression = PNG_ITXT_COMPRESSION_NONE;  // UTF-8 (a path with accents), which tEXt cannot hold
      t.itxt_length = values.back().size();
    }
  }
  if (!encode_header(m->p, m->info, &m->ctx, &m->header, chunks.data(), int(chunks.size()), linear)) m->failed();
}

Writer::~Writer() = default;

void Writer::write_rows(const void* pixels, int rows) {
  if (rows < 0 || m->next_row + rows > m->header.height)
    fail(m->stage, "{}: rows {}..{} past the image's {}", output_name(m->ctx.file->tmp()), m->next_row,
         m->next_row + rows, m->header.height);
  std::vector<png_bytep> ptr(static_cast<size_t>(rows));
  auto* base = static_cast<png_bytep>(const_cast<void*>(pixels));
  for (size_t y = 0; y < ptr.size(); ++y) ptr[y] = base + y * m->stride;
  if (rows > 0 && !encode_rows(m->p, ptr.data(), rows)) m->failed();
  m->next_row += rows;
}

void Writer::finish() {
  if (m->next_row != m->header.height)
    fail(m->stage, "{}: only {} of {} rows written", output_name(m->ctx.file->tmp()), m->next_row, m->header.height);
  if (!encode_end(m->p, m->info)) m->failed();
  m->ctx.file->check(m->stage);
}

void write(CheckedImageFile& file, int width, int height, int channels, int bit_depth, const void* pixels,
           const TextChunks& text, bool linear, const char* stage) {
  Writer w(file, width, height, channels, bit_depth, text, linear, stage);
  w.write_rows(pixels, height);
  w.finish();
}

}  // namespace terracl::io::png
