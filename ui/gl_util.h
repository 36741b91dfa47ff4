// Small RAII wrappers over the OpenGL objects the editor uses: shader programs (sources from
// shaders/, embedded at build time), textures, an offscreen framebuffer for the 3D view, and vertex
// buffers. Only the UI thread touches them.
#pragma once

#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "gl.h"

namespace montage {

// The shader sources of shaders/ by file name ("mesh.vert"), compiled into the binary so that the
// editor runs from any folder.
const std::map<std::string, std::string>& embeddedShaders();

class ShaderProgram {
 public:
  ShaderProgram() = default;
  // Compiles and links; throws montage::Error with the file name and the driver's log.
  ShaderProgram(const std::string& vertexFile, const std::string& fragmentFile);
  ~ShaderProgram();
  ShaderProgram(ShaderProgram&& o) noexcept { *this = std::move(o); }
  ShaderProgram& operator=(ShaderProgram&& o) noexcept;
  ShaderProgram(const ShaderProgram&) = delete;
  ShaderProgram& operator=(const ShaderProgram&) = delete;

  void use() const { glUseProgram(id_); }
  GLint uniform(const char* name) const;  // cached glGetUniformLocation
  GLuint id() const { return id_; }

 private:
  GLuint id_ = 0;
  mutable std::map<std::string, GLint> uniforms_;
};

class Texture {
 public:
  Texture() = default;
  ~Texture();
  Texture(Texture&& o) noexcept { *this = std::move(o); }
  Texture& operator=(Texture&& o) noexcept;
  Texture(const Texture&) = delete;
  Texture& operator=(const Texture&) = delete;

  // Uploads a CV_8UC4 RGBA image (row 0 = top, stored as texture row 0 so v = 0 is the top of the
  // image) with mipmaps.
  void upload(const cv::Mat& rgba);
  // Uploads a CV_8UC1 image as the alpha of white (RGB read as 1, swizzled): drawn with a tint colour, a tint
  // whose opacity follows the image, at a quarter of an RGBA upload's bytes. With mipmaps.
  void uploadAlpha(const cv::Mat& alpha);
  GLuint id() const { return id_; }
  int width() const { return width_; }
  int height() const { return height_; }
  bool valid() const { return id_ != 0; }

 private:
  // `image` as the texture's level 0 in `internalFormat`, its channels read through `swizzle`, with mipmaps.
  void uploadImage(const cv::Mat& image, GLint internalFormat, GLenum format, const GLint swizzle[4]);
  GLuint id_ = 0;
  int width_ = 0, height_ = 0;
};

// Colour texture + depth buffer to render the 3D view into; the ImGui window shows the texture.
class Framebuffer {
 public:
  Framebuffer() = default;
  ~Framebuffer();
  Framebuffer(const Framebuffer&) = delete;
  Framebuffer& operator=(const Framebuffer&) = delete;
  // (Re)allocates when the size changed. Throws montage::Error when the framebuffer is incomplete.
  void resize(int width, int height);
  void bind() const;
  // Linear filtering of the colour texture (shown stretched over a bigger view), else nearest.
  void setLinearFilter(bool linear);
  GLuint colorTexture() const { return color_; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  void release();
  GLuint fbo_ = 0, color_ = 0, depth_ = 0;
  int width_ = 0, height_ = 0;
  bool linear_ = false;
};

// A vertex array with one interleaved float buffer and a fixed attribute layout.
class VertexBuffer {
 public:
  struct Attribute {
    GLuint location;
    GLint components;  // floats
  };
  VertexBuffer() = default;
  ~VertexBuffer();
  VertexBuffer(const VertexBuffer&) = delete;
  VertexBuffer& operator=(const VertexBuffer&) = delete;
  // Uploads `data` (interleaved, attributes in order) and sets the layout.
  void upload(const std::vector<float>& data, const std::vector<Attribute>& layout);
  void draw(GLenum mode, int first, int count) const;
  int vertices() const { return vertices_; }
  // A second buffer for one attribute updated on its own (the mesh's overlay colours).
  void uploadSeparate(GLuint location, GLint components, const std::vector<float>& data);

 private:
  GLuint vao_ = 0, vbo_ = 0, extra_ = 0;
  int vertices_ = 0;
};

// Reads the default framebuffer (the whole window) as a CV_8UC4 RGBA image, row 0 = top.
cv::Mat readWindowPixels(int width, int height);
// Same for the bound framebuffer region.
cv::Mat readPixels(int x, int y, int width, int height);

}  // namespace montage
