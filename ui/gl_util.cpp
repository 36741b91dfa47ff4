#include "gl_util.h"

#include <utility>

#include "base/common.h"

namespace montage {

namespace {

GLuint compile(GLenum type, const std::string& file) {
  const auto& shaders = embeddedShaders();
  const auto it = shaders.find(file);
  TM_CHECK(it != shaders.end(), "shaders/" + file + ": not built into this binary (re-run cmake)");
  const GLuint shader = glCreateShader(type);
  const char* text = it->second.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetShaderInfoLog(shader, sizeof(log), nullptr, log);
    glDeleteShader(shader);
    throw Error("shaders/" + file + ": does not compile: " + log);
  }
  return shader;
}

}  // namespace

ShaderProgram::ShaderProgram(const std::string& vertexFile, const std::string& fragmentFile) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertexFile);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fragmentFile);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  id_ = glCreateProgram();
  glAttachShader(id_, vs);
  glAttachShader(id_, fs);
  glLinkProgram(id_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(id_, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096] = {};
    glGetProgramInfoLog(id_, sizeof(log), nullptr, log);
    glDeleteProgram(id_);
    id_ = 0;
    throw Error("shaders/" + vertexFile + " + " + fragmentFile + ": do not link: " + log);
  }
}

ShaderProgram::~ShaderProgram() {
  if (id_) glDeleteProgram(id_);
}

ShaderProgram& ShaderProgram::operator=(ShaderProgram&& o) noexcept {
  std::swap(id_, o.id_);
  std::swap(uniforms_, o.uniforms_);
  return *this;
}

GLint ShaderProgram::uniform(const char* name) const {
  auto it = uniforms_.find(name);
  if (it == uniforms_.end()) it = uniforms_.emplace(name, glGetUniformLocation(id_, name)).first;
  return it->second;
}

Texture::~Texture() {
  if (id_) glDeleteTextures(1, &id_);
}

Texture& Texture::operator=(Texture&& o) noexcept {
  std::swap(id_, o.id_);
  std::swap(width_, o.width_);
  std::swap(height_, o.height_);
  return *this;
}

void Texture::upload(const cv::Mat& rgba) {
  TM_ASSERT(rgba.type() == CV_8UC4);
  const GLint straight[4] = {GL_RED, GL_GREEN, GL_BLUE, GL_ALPHA};
  uploadImage(rgba, GL_RGBA8, GL_RGBA, straight);
}

void Texture::uploadAlpha(const cv::Mat& alpha) {
  TM_ASSERT(alpha.type() == CV_8UC1);
  const GLint white[4] = {GL_ONE, GL_ONE, GL_ONE, GL_RED};
  uploadImage(alpha, GL_R8, GL_RED, white);
}

void Texture::uploadImage(const cv::Mat& image, GLint internalFormat, GLenum format, const GLint swizzle[4]) {
  if (!id_) glGenTextures(1, &id_);
  glBindTexture(GL_TEXTURE_2D, id_);
  const cv::Mat continuous = image.isContinuous() ? image : image.clone();
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, internalFormat, continuous.cols, continuous.rows, 0, format, GL_UNSIGNED_BYTE,
               continuous.data);
  glTexParameteriv(GL_TEXTURE_2D, GL_TEXTURE_SWIZZLE_RGBA, swizzle);
  glGenerateMipmap(GL_TEXTURE_2D);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  width_ = continuous.cols;
  height_ = continuous.rows;
}

Framebuffer::~Framebuffer() {
  release();
}

void Framebuffer::release() {
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (color_) glDeleteTextures(1, &color_);
  if (depth_) glDeleteRenderbuffers(1, &depth_);
  fbo_ = color_ = depth_ = 0;
  width_ = height_ = 0;
  linear_ = false;
}

void Framebuffer::resize(int width, int height) {
  width = std::max(width, 1);
  height = std::max(height, 1);
  if (fbo_ && width == width_ && height == height_) return;
  release();
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glGenTextures(1, &color_);
  glBindTexture(GL_TEXTURE_2D, color_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color_, 0);
  glGenRenderbuffers(1, &depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth_);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  TM_CHECK(status == GL_FRAMEBUFFER_COMPLETE, "3D view: the OpenGL framebuffer of " + std::to_string(width) + "x" +
                                                  std::to_string(height) + " is incomplete (status " +
                                                  std::to_string(status) + ")");
  width_ = width;
  height_ = height;
}

void Framebuffer::setLinearFilter(bool linear) {
  if (!color_ || linear == linear_) return;
  linear_ = linear;
  glBindTexture(GL_TEXTURE_2D, color_);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, linear ? GL_LINEAR : GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, linear ? GL_LINEAR : GL_NEAREST);
}

void Framebuffer::bind() const {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
}

VertexBuffer::~VertexBuffer() {
  if (vbo_) glDeleteBuffers(1, &vbo_);
  if (extra_) glDeleteBuffers(1, &extra_);
  if (vao_) glDeleteVertexArrays(1, &vao_);
}

void VertexBuffer::upload(const std::vector<float>& data, const std::vector<Attribute>& layout) {
  if (!vao_) glGenVertexArrays(1, &vao_);
  if (!vbo_) glGenBuffers(1, &vbo_);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_STATIC_DRAW);
  int stride = 0;
  for (const auto& a : layout) stride += a.components;
  size_t offset = 0;
  for (const auto& a : layout) {
    glEnableVertexAttribArray(a.location);
    glVertexAttribPointer(a.location, a.components, GL_FLOAT, GL_FALSE, stride * sizeof(float),
                          reinterpret_cast<const void*>(offset * sizeof(float)));
    offset += a.components;
  }
  vertices_ = stride ? static_cast<int>(data.size() / stride) : 0;
  glBindVertexArray(0);
}

void VertexBuffer::uploadSeparate(GLuint location, GLint components, const std::vector<float>& data) {
  if (!vao_) glGenVertexArrays(1, &vao_);
  if (!extra_) glGenBuffers(1, &extra_);
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, extra_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_DYNAMIC_DRAW);
  glEnableVertexAttribArray(location);
  glVertexAttribPointer(location, components, GL_FLOAT, GL_FALSE, components * sizeof(float), nullptr);
  glBindVertexArray(0);
}

void VertexBuffer::draw(GLenum mode, int first, int count) const {
  if (!vao_ || count <= 0) return;
  glBindVertexArray(vao_);
  glDrawArrays(mode, first, count);
  glBindVertexArray(0);
}

cv::Mat readPixels(int x, int y, int width, int height) {
  cv::Mat flipped(height, width, CV_8UC4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(x, y, width, height, GL_RGBA, GL_UNSIGNED_BYTE, flipped.data);
  cv::Mat out;
  cv::flip(flipped, out, 0);  // GL rows run bottom-up
  return out;
}

cv::Mat readWindowPixels(int width, int height) {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  return readPixels(0, 0, width, height);
}

}  // namespace montage
