// SPDX-License-Identifier: Apache-2.0
#include "io/exr_codec.hpp"

#include "io/checked_output.hpp"

#include <terracl/error.hpp>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>

namespace terracl::io::exr {
namespace {

int threads() {
  // One pool per process, sized once: OpenEXR compresses and decompresses line blocks on it.
  static std::once_flag once;
  std::call_once(once, [] {
    if (Imf::globalThreadCount() == 0) Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency())));
  });
  return Imf::globalThreadCount();
}

bool is_required_attribute(const std::string& k) {
  for (const char* r : {"channels", "compression", "dataWindow", "displayWindow", "lineOrder", "pixelAspectRatio",
                        "screenWindowCenter", "screenWindowWidth", "tiles", "type", "name", "version", "chunkCount"})
    if (k == r) return true;
  return false;
}

// OpenEXR writes its line offset table last, seeking back to it: the stream must seek.
class FileStream : public Imf::OStream {
 public:
  explicit FileStream(CheckedImageFile& file) : Imf::OStream(file.tmp().c_str()), m_file(file) {}
  void write(const char c[], int n) override {
    if (!m_file.write(c, size_t(n))) throw std::runtime_error("write failed");
  }
  uint64_t tellp() override { return m_file.tell(); }
  void seekp(uint64_t pos) override {
    if (!m_file.seek(pos)) throw std::runtime_error("seek failed");
  }

 private:
  CheckedImageFile& m_file;
};

}  // namespace

struct Reader::Impl {
  std::string path;
  const char* stage;
  std::unique_ptr<Imf::InputFile> in;
  Header header;
  int x0 = 0, y0 = 0;  // data window origin

  template <class T>
  void read(int r0, int r1, const std::vector<std::string>& names, Imf::PixelType type, T* out) {
    if (r0 < 0 || r1 < r0 || r1 > header.height)
      fail(stage, "{}: rows [{}, {}) are outside the image's {} rows", path, r0, r1, header.height);
    if (r1 == r0) return;
    const size_t n = names.size();
    const size_t xs = sizeof(T) * n, ys = xs * size_t(header.width);
    // OpenEXR addresses a slice by absolute (x, y): shift the base so (x0, y0 + r0) lands on out[0].
    char* base = reinterpret_cast<char*>(out) - ptrdiff_t(x0) * ptrdiff_t(xs) - ptrdiff_t(y0 + r0) * ptrdiff_t(ys);
    Imf::FrameBuffer fb;
    for (size_t c = 0; c < n; ++c) fb.insert(names[c], Imf::Slice(type, base + c * sizeof(T), xs, ys));
    try {
      in->setFrameBuffer(fb);
      in->readPixels(y0 + r0, y0 + r1 - 1);
    } catch (const std::exception& e) {
      fail(stage, "{}: reading pixels failed: {}", path, e.what());
    }
  }
};

Reader::Reader(const std::string& path, const char* stage) : m(std::make_unique<Impl>()) {
  m->path = path;
  m->stage = stage;
  try {
    m->in = std::make_unique<Imf::InputFile>(path.c_str(), threads());
    const Imf::Header& h = m->in->header();
    const Imath::Box2i dw = h.dataWindow();
    m->x0 = dw.min.x;
    m->y0 = dw.min.y;
    m->header.width = dw.max.x - dw.min.x + 1;
    m->header.height = dw.max.y - dw.min.y + 1;
    for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
      m->header.channels.push_back(it.name());
      if (it.channel().type == Imf::UINT) m->header.all_float = false;
    }
    for (auto it = h.begin(); it != h.end(); ++it)
      if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
        m->header.strings.emplace_back(it.name(), s->value());
  } catch (const std::exception& e) {
    fail(stage, "{}: not an EXR OpenEXR can read ({})", path, e.what());
  }
}

Reader::~Reader() = default;

const Header& Reader::header() const { return m->header; }

void Reader::read_float(int y0, int y1, const std::vector<std::string>& channels, float* out) {
  m->read(y0, y1, channels, Imf::FLOAT, out);
}

void Reader::read_uint(int y0, int y1, const std::string& channel, uint32_t* out) {
  m->read(y0, y1, {channel}, Imf::UINT, out);
}

void write_float(CheckedImageFile& file, int width, int height, const std::vector<std::string>& channels,
                 const float* pixels, const Attributes& attributes, const char* stage) {
  try {
    Imf::Header h(width, height);
    h.compression() = Imf::ZIP_COMPRESSION;
    for (const auto& name : channels) h.channels().insert(name, Imf::Channel(Imf::FLOAT));
    // A metadata key may repeat one of ours with another type, or name one of the attributes every
    // EXR header must have: the later value wins, and the required ones are never replaced.
    auto put = [&](const std::string& k, const Imf::Attribute& a) {
      if (k.empty() || is_required_attribute(k)) return;
      if (h.find(k) != h.end()) h.erase(k);
      h.insert(k, a);
    };
    for (const auto& [k, v] : attributes.strings) put(k, Imf::StringAttribute(v));
    for (const auto& [k, v] : attributes.floats) put(k, Imf::FloatAttribute(v));
    const size_t n = channels.size();
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(const_cast<float*>(pixels));
    for (size_t c = 0; c < n; ++c)
      fb.insert(channels[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(float) * n,
                                        sizeof(float) * n * size_t(width)));
    FileStream os(file);
    Imf::OutputFile out(os, h, threads());
    out.setFrameBuffer(fb);
    out.writePixels(height);
  } catch (const std::exception& e) {
    file.check(stage);  // a write error's errno says more than OpenEXR's message
    fail(stage, "cannot write {}: {}", output_name(file.tmp()), name_output(e.what(), file.tmp()));
  }
  file.check(stage);
}

}  // namespace terracl::io::exr
