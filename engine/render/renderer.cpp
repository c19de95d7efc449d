#include "engine/render/renderer.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "engine/render/gl.hpp"

namespace palplab::render {

namespace {

const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_nrm;
layout(location = 2) in int a_region;
layout(location = 3) in int a_refined;
uniform mat4 u_view;
uniform mat4 u_proj;
uniform vec4 u_model;  // xyz offset, w scale (the marker); identity for the surface
uniform int u_mode;    // 0 shaded surface, 1 wireframe, 2 solid shaded (marker), 3 2D overlay
out vec3 v_pos;
out vec3 v_nrm;
flat out int v_region;
flat out int v_refined;
void main() {
  if (u_mode == 3) {
    gl_Position = vec4(a_pos.xy, 0.0, 1.0);
    return;
  }
  vec4 p = u_view * vec4(a_pos * u_model.w + u_model.xyz, 1.0);
  v_pos = p.xyz;
  v_nrm = mat3(u_view) * a_nrm;
  v_region = a_region;
  v_refined = a_refined;
  gl_Position = u_proj * p;
}
)";

const char* kFragmentShader = R"(#version 330 core
in vec3 v_pos;
in vec3 v_nrm;
flat in int v_region;
flat in int v_refined;
uniform int u_mode;
uniform vec4 u_colour[33];  // region colours and alphas; [32] = unlabelled
uniform vec4 u_solid;       // wireframe / marker / overlay colour
uniform int u_highlight;
out vec4 frag;
void main() {
  if (u_mode == 1 || u_mode == 3) {
    frag = u_solid;
    return;
  }
  vec4 base = u_mode == 2 ? u_solid
                          : u_colour[(v_region >= 0 && v_region < 32) ? v_region : 32];
  if (u_mode == 0 && u_highlight != 0 && v_refined != 0)
    base.rgb = mix(base.rgb, vec3(1.0, 0.85, 0.1), 0.65);
  // Headlight shading (light at the eye), two-sided so inner faces seen through a transparent
  // region are lit too.
  vec3 n = normalize(v_nrm);
  if (!gl_FrontFacing) n = -n;
  vec3 l = normalize(-v_pos);
  float diff = max(dot(n, l), 0.0);
  float spec = pow(diff, 40.0);  // Blinn-Phong; half vector = l for a headlight
  frag = vec4(base.rgb * (0.22 + 0.78 * diff) + vec3(0.18 * spec), base.a);
}
)";

GLuint compile(GLenum type, const char* src) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    throw std::runtime_error(std::string("renderer: shader compilation failed: ") + log);
  }
  return s;
}

// Unit sphere for the contact marker: an octahedron subdivided twice.
void make_sphere(std::vector<float>& verts, std::vector<unsigned>& idx) {
  std::vector<Eigen::Vector3f> p = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                    {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
  std::vector<std::array<unsigned, 3>> f = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                            {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int level = 0; level < 3; ++level) {
    std::vector<std::array<unsigned, 3>> g;
    for (const auto& t : f) {
      unsigned m[3];
      for (int k = 0; k < 3; ++k) {
        p.push_back((p[t[k]] + p[t[(k + 1) % 3]]).normalized());
        m[k] = static_cast<unsigned>(p.size() - 1);
      }
      g.push_back({t[0], m[0], m[2]});
      g.push_back({m[0], t[1], m[1]});
      g.push_back({m[2], m[1], t[2]});
      g.push_back({m[0], m[1], m[2]});
    }
    f.swap(g);
  }
  verts.clear();
  for (const auto& q : p)
    for (int k = 0; k < 2; ++k) verts.insert(verts.end(), {q.x(), q.y(), q.z()});
  idx.clear();
  for (const auto& t : f) idx.insert(idx.end(), t.begin(), t.end());
}

}  // namespace

std::array<float, 3> region_colour(int r) {
  // Distinguishable tissue-like hues (sRGB-ish), cycled for many regions.
  static const std::array<std::array<float, 3>, 10> palette = {{{0.84f, 0.47f, 0.45f},
                                                                {0.47f, 0.66f, 0.86f},
                                                                {0.55f, 0.78f, 0.47f},
                                                                {0.88f, 0.70f, 0.38f},
                                                                {0.68f, 0.52f, 0.82f},
                                                                {0.42f, 0.78f, 0.76f},
                                                                {0.90f, 0.56f, 0.72f},
                                                                {0.70f, 0.64f, 0.50f},
                                                                {0.60f, 0.60f, 0.90f},
                                                                {0.80f, 0.80f, 0.45f}}};
  if (r < 0) return {0.72f, 0.70f, 0.68f};
  return palette[static_cast<size_t>(r) % palette.size()];
}

struct Renderer::Gl {
  GLuint program = 0;
  GLuint vao = 0, vbo_stream = 0, vbo_attr = 0, ebo = 0, ebo_transparent = 0;
  GLuint marker_vao = 0, marker_vbo = 0, marker_ebo = 0;
  GLsizei marker_count = 0;
  GLuint overlay_vao = 0, overlay_vbo = 0;
  GLint u_view = -1, u_proj = -1, u_model = -1, u_mode = -1, u_colour = -1, u_solid = -1,
        u_highlight = -1;
};

Renderer::Renderer(const engine::SceneGeometry& rest) : gl_(std::make_unique<Gl>()), rest_(rest) {
  bounding_sphere(rest.V, centre_, radius_);
  rest_faces_ = rest.F.rows();
  if (rest.tissues) inner_ = rest.tissues;
  Gl& g = *gl_;
  g.program = glCreateProgram();
  const GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  glAttachShader(g.program, vs);
  glAttachShader(g.program, fs);
  glLinkProgram(g.program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(g.program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048] = {};
    glGetProgramInfoLog(g.program, sizeof log, nullptr, log);
    throw std::runtime_error(std::string("renderer: shader link failed: ") + log);
  }
  g.u_view = glGetUniformLocation(g.program, "u_view");
  g.u_proj = glGetUniformLocation(g.program, "u_proj");
  g.u_model = glGetUniformLocation(g.program, "u_model");
  g.u_mode = glGetUniformLocation(g.program, "u_mode");
  g.u_colour = glGetUniformLocation(g.program, "u_colour");
  g.u_solid = glGetUniformLocation(g.program, "u_solid");
  g.u_highlight = glGetUniformLocation(g.program, "u_highlight");

  glGenVertexArrays(1, &g.vao);
  glGenBuffers(1, &g.vbo_stream);
  glGenBuffers(1, &g.vbo_attr);
  glGenBuffers(1, &g.ebo);
  glGenBuffers(1, &g.ebo_transparent);

  // Marker sphere: uploaded once.
  std::vector<float> mv;
  std::vector<unsigned> mi;
  make_sphere(mv, mi);
  g.marker_count = static_cast<GLsizei>(mi.size());
  glGenVertexArrays(1, &g.marker_vao);
  glGenBuffers(1, &g.marker_vbo);
  glGenBuffers(1, &g.marker_ebo);
  glBindVertexArray(g.marker_vao);
  glBindBuffer(GL_ARRAY_BUFFER, g.marker_vbo);
  glBufferData(GL_ARRAY_BUFFER, mv.size() * sizeof(float), mv.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.marker_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, mi.size() * sizeof(unsigned), mi.data(), GL_STATIC_DRAW);

  glGenVertexArrays(1, &g.overlay_vao);
  glGenBuffers(1, &g.overlay_vbo);
  glBindVertexArray(g.overlay_vao);
  glBindBuffer(GL_ARRAY_BUFFER, g.overlay_vbo);
  glBufferData(GL_ARRAY_BUFFER, 6 * 3 * sizeof(float), nullptr, GL_DYNAMIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glEnableVertexAttribArray(0);
  glBindVertexArray(0);

  // The rest surface, so a renderer can draw before the first update.
  update_surface(rest.V, rest.F, rest.V.rows());
}

Renderer::~Renderer() {
  Gl& g = *gl_;
  glDeleteBuffers(1, &g.vbo_stream);
  glDeleteBuffers(1, &g.vbo_attr);
  glDeleteBuffers(1, &g.ebo);
  glDeleteBuffers(1, &g.ebo_transparent);
  glDeleteBuffers(1, &g.marker_vbo);
  glDeleteBuffers(1, &g.marker_ebo);
  glDeleteBuffers(1, &g.overlay_vbo);
  glDeleteVertexArrays(1, &g.vao);
  glDeleteVertexArrays(1, &g.marker_vao);
  glDeleteVertexArrays(1, &g.overlay_vao);
  glDeleteProgram(g.program);
}

CameraMatrices Renderer::matrices(const Camera& cam, int width, int height) const {
  return camera_matrices(cam, centre_, radius_, width, height);
}

void Renderer::upload_topology(long nV) {
  Gl& g = *gl_;
  // Regions in the current numbering. The scene's current surface may number its nodes
  // differently from the rest geometry (tetrahedral models list interior nodes; refinement adds
  // nodes), so a vertex takes the region of the nearest rest surface node — exact for unchanged
  // numbering, and right for refinement nodes, which lie inside the faces they split.
  vertex_region_.assign(nV, -1);
  vertex_refined_.assign(nV, 0);
  // The tissues' surfaces (needle scenes) follow the scene's surface, with their own regions.
  const long outer_faces = F_.rows() - (inner_ ? inner_->F.rows() : 0);
  const bool same = outer_vertices_ == rest_.V.rows() && outer_faces == rest_.F.rows() &&
                    F_.topRows(outer_faces) == rest_.F;
  std::vector<char> used(nV, 0);
  for (long f = 0; f < F_.rows(); ++f)
    for (int k = 0; k < 3; ++k) used[F_(f, k)] = 1;
  for (long v = 0; v < nV; ++v) {
    if (v >= outer_vertices_) {
      vertex_region_[v] = inner_->vertex_region[v - outer_vertices_];
      continue;
    }
    if (!used[v]) continue;
    const int node = same ? static_cast<int>(v) : rest_.nearest_node(V_.row(v).transpose());
    vertex_region_[v] = node >= 0 && node < static_cast<int>(rest_.vertex_region.size())
                            ? rest_.vertex_region[node]
                            : -1;
    vertex_refined_[v] = v >= coarse_nodes_ ? 1 : 0;
  }
  face_region_.resize(F_.rows());
  for (long f = 0; f < F_.rows(); ++f) face_region_[f] = vertex_region_[F_(f, 0)];
  // A face is highlighted through its provoking (first) vertex: flag the first vertex of every
  // face that touches a refinement node. Faces sharing that vertex but not touching refinement
  // nodes are rare (corner faces of a split) and read as part of the patch.
  std::vector<int> first_flag(nV, 0);
  for (long f = 0; f < F_.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (vertex_refined_[F_(f, k)]) first_flag[F_(f, 0)] = 1;
  std::vector<int> attr(2 * nV);
  for (long v = 0; v < nV; ++v) {
    attr[2 * v] = vertex_region_[v];
    attr[2 * v + 1] = first_flag[v];
  }
  glBindVertexArray(g.vao);
  if (nV > vertex_capacity_) {
    vertex_capacity_ = std::max<long>(nV, vertex_capacity_ * 3 / 2);
    glBindBuffer(GL_ARRAY_BUFFER, g.vbo_stream);
    glBufferData(GL_ARRAY_BUFFER, vertex_capacity_ * 6 * sizeof(float), nullptr, GL_STREAM_DRAW);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                          reinterpret_cast<void*>(3 * sizeof(float)));
    glEnableVertexAttribArray(0);
    glEnableVertexAttribArray(1);
    glBindBuffer(GL_ARRAY_BUFFER, g.vbo_attr);
    glBufferData(GL_ARRAY_BUFFER, vertex_capacity_ * 2 * sizeof(int), nullptr, GL_DYNAMIC_DRAW);
    glVertexAttribIPointer(2, 1, GL_INT, 2 * sizeof(int), nullptr);
    glVertexAttribIPointer(3, 1, GL_INT, 2 * sizeof(int), reinterpret_cast<void*>(sizeof(int)));
    glEnableVertexAttribArray(2);
    glEnableVertexAttribArray(3);
  }
  glBindBuffer(GL_ARRAY_BUFFER, g.vbo_attr);
  glBufferSubData(GL_ARRAY_BUFFER, 0, attr.size() * sizeof(int), attr.data());
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ebo);
  std::vector<unsigned> idx(F_.size());
  for (long f = 0; f < F_.rows(); ++f)
    for (int k = 0; k < 3; ++k) idx[3 * f + k] = static_cast<unsigned>(F_(f, k));
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, idx.size() * sizeof(unsigned), idx.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  ++faces_uploaded_;
}

void Renderer::update_surface(const RowMatX3d& V_in, const RowMatX3i& F_in, long coarse_nodes) {
  if (F_in.size() > 0 && (F_in.minCoeff() < 0 || F_in.maxCoeff() >= V_in.rows()))
    throw std::invalid_argument("Renderer::update_surface: a face refers to a missing vertex");
  outer_vertices_ = V_in.rows();
  outer_faces_ = F_in.rows();
  RowMatX3d V_all;
  RowMatX3i F_all;
  if (inner_) {  // the tissues' surfaces after the scene's, numbered after its vertices
    V_all.resize(V_in.rows() + inner_->V.rows(), 3);
    V_all << V_in, inner_->V;
    F_all.resize(F_in.rows() + inner_->F.rows(), 3);
    F_all << F_in, (inner_->F.array() + static_cast<int>(V_in.rows())).matrix();
  }
  const RowMatX3d& V = inner_ ? V_all : V_in;
  const RowMatX3i& F = inner_ ? F_all : F_in;
  const long nV = V.rows();
  V_ = V;
  const bool topology = F.rows() != F_.rows() || F != F_ || nV > vertex_capacity_ ||
                        coarse_nodes != coarse_nodes_ ||
                        static_cast<long>(vertex_region_.size()) != nV;
  if (topology) {
    F_ = F;
    coarse_nodes_ = coarse_nodes;
    upload_topology(nV);
  }
  // Area-weighted vertex normals of the deformed surface.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> N = RowMatX3d::Zero(nV, 3);
  for (long f = 0; f < F_.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F_(f, 0)), b = V.row(F_(f, 1)), c = V.row(F_(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) N.row(F_(f, k)) += n.transpose();
  }
  stream_.resize(static_cast<size_t>(nV) * 6);
  for (long v = 0; v < nV; ++v) {
    const double len = N.row(v).norm();
    for (int k = 0; k < 3; ++k) {
      stream_[6 * v + k] = static_cast<float>(V(v, k));
      stream_[6 * v + 3 + k] = static_cast<float>(len > 0 ? N(v, k) / len : 0.0);
    }
  }
  glBindBuffer(GL_ARRAY_BUFFER, gl_->vbo_stream);
  glBufferSubData(GL_ARRAY_BUFFER, 0, stream_.size() * sizeof(float), stream_.data());
  glBindBuffer(GL_ARRAY_BUFFER, 0);
}

void Renderer::draw(const Camera& cam, int width, int height, const DrawOptions& opt) {
  Gl& g = *gl_;
  const CameraMatrices m = matrices(cam, width, height);
  glViewport(0, 0, width, height);
  glClearColor(opt.background[0], opt.background[1], opt.background[2], 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);
  glProvokingVertex(GL_FIRST_VERTEX_CONVENTION);
  glUseProgram(g.program);
  const Eigen::Matrix4f view = m.view.cast<float>(), proj = m.proj.cast<float>();
  glUniformMatrix4fv(g.u_view, 1, GL_FALSE, view.data());  // Eigen is column-major like GL
  glUniformMatrix4fv(g.u_proj, 1, GL_FALSE, proj.data());
  glUniform4f(g.u_model, 0, 0, 0, 1);
  std::array<float, 4 * (kMaxRegions + 1)> colours{};
  auto alpha_of = [&](int r) {
    return r >= 0 && r < static_cast<int>(opt.region_alpha.size())
               ? std::clamp(opt.region_alpha[r], 0.0f, 1.0f)
               : 1.0f;
  };
  for (int r = 0; r <= kMaxRegions; ++r) {
    const int reg = r < kMaxRegions ? r : -1;
    const auto c = region_colour(reg);
    colours[4 * r] = c[0];
    colours[4 * r + 1] = c[1];
    colours[4 * r + 2] = c[2];
    colours[4 * r + 3] = reg >= 0 ? alpha_of(reg) : 1.0f;
  }
  glUniform4fv(g.u_colour, kMaxRegions + 1, colours.data());
  glUniform1i(g.u_highlight, opt.highlight_refined && outer_faces_ > rest_faces_ ? 1 : 0);

  // Split faces into opaque and transparent by their region's alpha.
  std::vector<unsigned> opaque, transparent_faces;
  bool any_transparent = false;
  for (float a : opt.region_alpha) any_transparent = any_transparent || a < 1.0f;
  glBindVertexArray(g.vao);
  glUniform1i(g.u_mode, 0);
  if (!any_transparent) {
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ebo);
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(F_.size()), GL_UNSIGNED_INT, nullptr);
  } else {
    opaque.reserve(F_.size());
    for (long f = 0; f < F_.rows(); ++f) {
      const int r = face_region_[f];
      const float a = r >= 0 && r < kMaxRegions ? alpha_of(r) : 1.0f;
      if (a >= 1.0f) {
        for (int k = 0; k < 3; ++k) opaque.push_back(static_cast<unsigned>(F_(f, k)));
      } else if (a > 0.0f) {
        transparent_faces.push_back(static_cast<unsigned>(f));
      }
    }
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ebo_transparent);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, opaque.size() * sizeof(unsigned), opaque.data(),
                 GL_STREAM_DRAW);
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(opaque.size()), GL_UNSIGNED_INT, nullptr);
  }
  if (opt.wireframe) {
    glUniform1i(g.u_mode, 1);
    glUniform4f(g.u_solid, 0.12f, 0.12f, 0.14f, 1.0f);
    glEnable(GL_POLYGON_OFFSET_LINE);
    glPolygonOffset(-1.0f, -1.0f);
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ebo);
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(F_.size()), GL_UNSIGNED_INT, nullptr);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glDisable(GL_POLYGON_OFFSET_LINE);
  }
  // Contact marker (opaque, so before the transparent pass).
  if (opt.device_position) {
    const double r = opt.marker_radius > 0 ? opt.marker_radius : 0.012 * radius_;
    glUniform1i(g.u_mode, 2);
    if (opt.contact)
      glUniform4f(g.u_solid, 0.95f, 0.0f, 0.85f, 1.0f);
    else
      glUniform4f(g.u_solid, 0.10f, 0.25f, 0.85f, 1.0f);
    const Eigen::Vector3d& p = *opt.device_position;
    glUniform4f(g.u_model, static_cast<float>(p.x()), static_cast<float>(p.y()),
                static_cast<float>(p.z()), static_cast<float>(r));
    glBindVertexArray(g.marker_vao);
    glDrawElements(GL_TRIANGLES, g.marker_count, GL_UNSIGNED_INT, nullptr);
    // Pressing puts the HCP inside the tissue: draw it once more through the surface, faint.
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    if (opt.contact)
      glUniform4f(g.u_solid, 0.95f, 0.0f, 0.85f, 0.5f);
    else
      glUniform4f(g.u_solid, 0.10f, 0.25f, 0.85f, 0.45f);
    glDrawElements(GL_TRIANGLES, g.marker_count, GL_UNSIGNED_INT, nullptr);
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
    glUniform4f(g.u_model, 0, 0, 0, 1);
  }
  // The needle (its tool in a needle scene): a row of small spheres from the tip back along the
  // shaft, opaque, so that it shows through transparent tissue.
  if (opt.device_position && opt.needle_axis && opt.needle_axis->norm() > 0) {
    const Eigen::Vector3d a = opt.needle_axis->normalized();
    const double r = 0.008 * radius_;  // about an 18 G needle at the shoulder scale
    const int n = std::max(2, static_cast<int>(std::ceil(opt.needle_length / r)));
    glUniform1i(g.u_mode, 2);
    glUniform4f(g.u_solid, 0.35f, 0.37f, 0.42f, 1.0f);
    glBindVertexArray(g.marker_vao);
    for (int i = 0; i <= n; ++i) {
      const Eigen::Vector3d p = *opt.device_position - (opt.needle_length * i / n) * a;
      glUniform4f(g.u_model, static_cast<float>(p.x()), static_cast<float>(p.y()),
                  static_cast<float>(p.z()), static_cast<float>(r));
      glDrawElements(GL_TRIANGLES, g.marker_count, GL_UNSIGNED_INT, nullptr);
    }
    glUniform4f(g.u_model, 0, 0, 0, 1);
  }
  // Transparent regions, back to front (face centroids by eye depth), without depth writes.
  if (!transparent_faces.empty()) {
    std::vector<std::pair<float, unsigned>> order;
    order.reserve(transparent_faces.size());
    const Eigen::Vector3d fwd = m.forward;
    for (unsigned f : transparent_faces) {
      const Eigen::Vector3d c =
          (V_.row(F_(f, 0)) + V_.row(F_(f, 1)) + V_.row(F_(f, 2))).transpose() / 3.0;
      order.emplace_back(static_cast<float>(fwd.dot(c - m.eye)), f);
    }
    std::sort(order.begin(), order.end(),
              [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<unsigned> idx;
    idx.reserve(order.size() * 3);
    for (const auto& [d, f] : order)
      for (int k = 0; k < 3; ++k) idx.push_back(static_cast<unsigned>(F_(f, k)));
    glBindVertexArray(g.vao);
    glUniform1i(g.u_mode, 0);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ebo_transparent);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, idx.size() * sizeof(unsigned), idx.data(),
                 GL_STREAM_DRAW);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(idx.size()), GL_UNSIGNED_INT, nullptr);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
  }
  glBindVertexArray(0);
}

void Renderer::overlay_rect(int width, int height, double x0, double y0, double x1, double y1,
                            const std::array<float, 4>& rgba) {
  Gl& g = *gl_;
  auto nx = [&](double x) { return static_cast<float>(2.0 * x / width - 1.0); };
  auto ny = [&](double y) { return static_cast<float>(1.0 - 2.0 * y / height); };
  const float v[18] = {nx(x0), ny(y0), 0, nx(x1), ny(y0), 0, nx(x1), ny(y1), 0,
                       nx(x0), ny(y0), 0, nx(x1), ny(y1), 0, nx(x0), ny(y1), 0};
  glUseProgram(g.program);
  glUniform1i(g.u_mode, 3);
  glUniform4f(g.u_solid, rgba[0], rgba[1], rgba[2], rgba[3]);
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  glBindVertexArray(g.overlay_vao);
  glBindBuffer(GL_ARRAY_BUFFER, g.overlay_vbo);
  glBufferSubData(GL_ARRAY_BUFFER, 0, sizeof v, v);
  glDrawArrays(GL_TRIANGLES, 0, 6);
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
}

}  // namespace palplab::render
