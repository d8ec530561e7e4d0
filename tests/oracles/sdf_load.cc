// Loads an SDF world with libsdformat (the parser Gazebo uses) and its heightmap with
// ign-common 4's ImageHeightmap (Gazebo Fortress's heightmap loader), and prints what they read
// as one JSON object on stdout, for tests/unit/world/export/test_export_gazebo.py.
//
// Build: g++ -std=c++17 sdf_load.cc $(pkg-config --cflags --libs sdformat12 ignition-common4-graphics)
// Usage: sdf_load WORLD.sdf
//
// Heightmap heights are filled as Gazebo does: the brightest pixel scales to the <size>'s height
// (scale.z = size.z / MaxElevation, or size.z when MaxElevation is 0), one vertex per pixel, with
// flipY (row 0 of the output is the image's bottom row, the south edge).
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <ignition/common/ImageHeightmap.hh>
#include <ignition/math/Pose3.hh>
#include <ignition/math/Vector3.hh>
#include <sdf/Box.hh>
#include <sdf/Collision.hh>
#include <sdf/Cylinder.hh>
#include <sdf/Geometry.hh>
#include <sdf/Heightmap.hh>
#include <sdf/Link.hh>
#include <sdf/Model.hh>
#include <sdf/Root.hh>
#include <sdf/Visual.hh>
#include <sdf/World.hh>

namespace {

std::string Quote(const std::string &s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') { out += "\\n"; continue; }
    out += c;
  }
  return out + "\"";
}

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(17);
  o << v;
  return o.str();
}

std::string Vec(const ignition::math::Vector3d &v) {
  return "[" + Num(v.X()) + "," + Num(v.Y()) + "," + Num(v.Z()) + "]";
}

std::string Pose(const ignition::math::Pose3d &p) {
  const auto r = p.Rot().Euler();
  return "[" + Num(p.Pos().X()) + "," + Num(p.Pos().Y()) + "," + Num(p.Pos().Z()) + "," +
         Num(r.X()) + "," + Num(r.Y()) + "," + Num(r.Z()) + "]";
}

std::string Heightmap(const sdf::Heightmap &hm, const std::string &sdfDir) {
  std::string uri = hm.Uri();
  std::filesystem::path path(uri);
  if (path.is_relative()) path = std::filesystem::path(sdfDir) / path;
  std::ostringstream o;
  o << "{\"uri\":" << Quote(uri) << ",\"size\":" << Vec(hm.Size()) << ",\"pos\":" << Vec(hm.Position());
  ignition::common::ImageHeightmap data;
  const int rc = data.Load(path.string());
  o << ",\"load_rc\":" << rc;
  if (rc == 0) {
    const unsigned int w = data.Width(), h = data.Height();
    const float maxElev = data.MaxElevation();
    const ignition::math::Vector3d size = hm.Size();
    ignition::math::Vector3d scale(size.X() / w, size.Y() / h,
                                   maxElev == 0.0f ? std::fabs(size.Z()) : std::fabs(size.Z()) / maxElev);
    std::vector<float> heights(static_cast<size_t>(w) * w);
    data.FillHeightMap(1, w, size, scale, true, heights);
    o << ",\"width\":" << w << ",\"height\":" << h << ",\"max_elevation\":" << Num(maxElev)
      << ",\"heights\":[";
    for (size_t i = 0; i < heights.size(); ++i) o << (i ? "," : "") << Num(heights[i]);
    o << "]";
  }
  o << "}";
  return o.str();
}

std::string Geometry(const sdf::Geometry *g, const std::string &sdfDir) {
  if (g == nullptr) return "null";
  switch (g->Type()) {
    case sdf::GeometryType::BOX:
      return "{\"type\":\"box\",\"size\":" + Vec(g->BoxShape()->Size()) + "}";
    case sdf::GeometryType::CYLINDER:
      return "{\"type\":\"cylinder\",\"radius\":" + Num(g->CylinderShape()->Radius()) +
             ",\"length\":" + Num(g->CylinderShape()->Length()) + "}";
    case sdf::GeometryType::HEIGHTMAP:
      return "{\"type\":\"heightmap\",\"heightmap\":" + Heightmap(*g->HeightmapShape(), sdfDir) + "}";
    default:
      return "{\"type\":\"other\"}";
  }
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 2) {
    std::cerr << "usage: sdf_load WORLD.sdf\n";
    return 2;
  }
  const std::string file = argv[1];
  const std::string dir = std::filesystem::absolute(file).parent_path().string();
  sdf::Root root;
  const sdf::Errors errors = root.Load(file);
  std::cout << "{\"errors\":[";
  for (size_t i = 0; i < errors.size(); ++i) {
    std::ostringstream e;
    e << errors[i];
    std::cout << (i ? "," : "") << Quote(e.str());
  }
  std::cout << "],\"worlds\":[";
  for (uint64_t wi = 0; wi < root.WorldCount(); ++wi) {
    const sdf::World *world = root.WorldByIndex(wi);
    std::cout << (wi ? "," : "") << "{\"name\":" << Quote(world->Name()) << ",\"models\":[";
    for (uint64_t mi = 0; mi < world->ModelCount(); ++mi) {
      const sdf::Model *m = world->ModelByIndex(mi);
      std::cout << (mi ? "," : "") << "{\"name\":" << Quote(m->Name())
                << ",\"static\":" << (m->Static() ? "true" : "false") << ",\"pose\":" << Pose(m->RawPose())
                << ",\"links\":[";
      for (uint64_t li = 0; li < m->LinkCount(); ++li) {
        const sdf::Link *l = m->LinkByIndex(li);
        std::cout << (li ? "," : "") << "{\"name\":" << Quote(l->Name()) << ",\"collisions\":[";
        for (uint64_t ci = 0; ci < l->CollisionCount(); ++ci) {
          const sdf::Collision *c = l->CollisionByIndex(ci);
          std::cout << (ci ? "," : "") << "{\"name\":" << Quote(c->Name()) << ",\"pose\":" << Pose(c->RawPose())
                    << ",\"geometry\":" << Geometry(c->Geom(), dir) << "}";
        }
        std::cout << "],\"visuals\":[";
        for (uint64_t vi = 0; vi < l->VisualCount(); ++vi) {
          const sdf::Visual *v = l->VisualByIndex(vi);
          std::cout << (vi ? "," : "") << "{\"name\":" << Quote(v->Name()) << ",\"pose\":" << Pose(v->RawPose())
                    << ",\"geometry\":" << Geometry(v->Geom(), dir) << "}";
        }
        std::cout << "]}";
      }
      std::cout << "]}";
    }
    std::cout << "]}";
  }
  std::cout << "]}\n";
  return errors.empty() ? 0 : 1;
}
