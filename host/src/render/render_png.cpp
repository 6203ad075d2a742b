// PNG output of rendered previews through OpenImageIO: the only part of rendering that needs an
// image library, kept apart so the core build (TERRACL_CORE_ONLY) renders to arrays without it.
#include <terracl/error.hpp>
#include <terracl/io.hpp>
#include <terracl/render.hpp>

#include <OpenImageIO/imageio.h>

namespace terracl::render {

void write_image(const Image& img, const std::string& path, const Metadata& meta) {
  if (img.pixels.size() != size_t(img.width) * img.height * img.channels) fail("render", "inconsistent image buffer");
  if (format_from_extension(path) != FileFormat::PNG)  // OIIO would write a JPEG for x.jpg
    fail("render", "{}: previews are written as PNG; use a .png name", path);
  write_atomically(path, [&](const std::string& tmp) {
    auto out = OIIO::ImageOutput::create(tmp);
    if (!out) fail("render", "cannot write {}: {}", path, OIIO::geterror());
    OIIO::ImageSpec spec(img.width, img.height, img.channels, OIIO::TypeDesc::UINT8);
    spec.attribute("Software", "terracl");
    for (const auto& [k, v] : meta) spec.attribute(k, v);  // PNG text chunks
    if (!out->open(tmp, spec)) fail("render", "cannot write {}: {}", path, out->geterror());
    if (!out->write_image(OIIO::TypeDesc::UINT8, img.pixels.data()))
      fail("render", "cannot write {}: {}", path, out->geterror());
    if (!out->close()) fail("render", "cannot write {}: {}", path, out->geterror());
  });
}

}  // namespace terracl::render
