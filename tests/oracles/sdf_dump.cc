// libsdformat's reading of a Gazebo world, the oracle of navstress's own SDF importer
// (src/navstress/world/sources/sdf.py; tests/unit/world/test_import_sdf.py): loads the file with
// sdf::Root (libsdformat 12, Gazebo Fortress's parser, which converts SDF 1.4 to 1.8 to 1.9 and
// resolves <include>s through SDF_PATH), walks every world's models (nested ones too), their
// links and collisions, resolves each collision's pose in the world frame with
// SemanticPose().Resolve (the collision in its model's frame, the model in the world or in its
// parent model, composed) and prints, per file, one line of JSON on stdout:
//
//   {"file": ..., "errors": [...], "worlds": [{"name": ..., "collisions": [
//      {"model": "outer::inner", "static": true, "link": ..., "name": ...,
//       "pose": [x, y, z, qw, qx, qy, qz], "geometry": {"type": "box", ...}}, ...]}]}
//
// The pose's rotation is a quaternion (no Euler-angle ambiguity). Geometry: box (size),
// cylinder (radius, length), sphere (radius), capsule (radius, length), ellipsoid (radii),
// plane (normal, size), mesh (uri, scale), heightmap (uri, size, pos), other.
//
// Build: g++ -std=c++17 sdf_dump.cc $(pkg-config --cflags --libs sdformat12)
// Usage: sdf_dump WORLD.sdf... (one line of JSON per file, the exit status 1 if any file had errors)
#include <cmath>
#include <iostream>
#include <sstream>
#include <string>

#include <ignition/math/Pose3.hh>
#include <ignition/math/Vector3.hh>
#include <sdf/Box.hh>
#include <sdf/Capsule.hh>
#include <sdf/Collision.hh>
#include <sdf/Cylinder.hh>
#include <sdf/Ellipsoid.hh>
#include <sdf/Geometry.hh>
#include <sdf/Heightmap.hh>
#include <sdf/Link.hh>
#include <sdf/Mesh.hh>
#include <sdf/Model.hh>
#include <sdf/Plane.hh>
#include <sdf/Root.hh>
#include <sdf/SemanticPose.hh>
#include <sdf/Sphere.hh>
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
  const auto &q = p.Rot();
  return "[" + Num(p.Pos().X()) + "," + Num(p.Pos().Y()) + "," + Num(p.Pos().Z()) + "," + Num(q.W()) + "," +
         Num(q.X()) + "," + Num(q.Y()) + "," + Num(q.Z()) + "]";
}

std::string Geometry(const sdf::Geometry *g) {
  if (g == nullptr) return "null";
  switch (g->Type()) {
    case sdf::GeometryType::BOX:
      return "{\"type\":\"box\",\"size\":" + Vec(g->BoxShape()->Size()) + "}";
    case sdf::GeometryType::CYLINDER:
      return "{\"type\":\"cylinder\",\"radius\":" + Num(g->CylinderShape()->Radius()) +
             ",\"length\":" + Num(g->CylinderShape()->Length()) + "}";
    case sdf::GeometryType::SPHERE:
      return "{\"type\":\"sphere\",\"radius\":" + Num(g->SphereShape()->Radius()) + "}";
    case sdf::GeometryType::CAPSULE:
      return "{\"type\":\"capsule\",\"radius\":" + Num(g->CapsuleShape()->Radius()) +
             ",\"length\":" + Num(g->CapsuleShape()->Length()) + "}";
    case sdf::GeometryType::ELLIPSOID:
      return "{\"type\":\"ellipsoid\",\"radii\":" + Vec(g->EllipsoidShape()->Radii()) + "}";
    case sdf::GeometryType::PLANE: {
      const auto *p = g->PlaneShape();
      return "{\"type\":\"plane\",\"normal\":" + Vec(p->Normal()) + ",\"size\":[" + Num(p->Size().X()) + "," +
             Num(p->Size().Y()) + "]}";
    }
    case sdf::GeometryType::MESH:
      return "{\"type\":\"mesh\",\"uri\":" + Quote(g->MeshShape()->Uri()) + ",\"scale\":" +
             Vec(g->MeshShape()->Scale()) + "}";
    case sdf::GeometryType::HEIGHTMAP: {
      const auto *h = g->HeightmapShape();
      return "{\"type\":\"heightmap\",\"uri\":" + Quote(h->Uri()) + ",\"size\":" + Vec(h->Size()) +
             ",\"pos\":" + Vec(h->Position()) + "}";
    }
    default:
      return "{\"type\":\"other\"}";
  }
}

bool first = true;

// m's collisions; X_WP: the world pose of the frame m's pose is resolved to (the world for a
// world's model, the parent model's frame for a nested one).
void Model(const sdf::Model *m, const std::string &prefix, bool parentStatic, const ignition::math::Pose3d &X_WP,
           const std::string &resolveTo) {
  const std::string name = prefix.empty() ? m->Name() : prefix + "::" + m->Name();
  ignition::math::Pose3d X_PM;
  sdf::Errors merrs = m->SemanticPose().Resolve(X_PM, resolveTo);
  for (const auto &e : merrs) std::cerr << name << ": " << e << "\n";
  const ignition::math::Pose3d X_WM = X_WP * X_PM;
  const bool isStatic = parentStatic || m->Static();
  for (uint64_t li = 0; li < m->LinkCount(); ++li) {
    const sdf::Link *l = m->LinkByIndex(li);
    for (uint64_t ci = 0; ci < l->CollisionCount(); ++ci) {
      const sdf::Collision *c = l->CollisionByIndex(ci);
      ignition::math::Pose3d X_MC;
      sdf::Errors errs = c->SemanticPose().Resolve(X_MC, "__model__");
      for (const auto &e : errs) std::cerr << name << "/" << c->Name() << ": " << e << "\n";
      errs.insert(errs.end(), merrs.begin(), merrs.end());
      const ignition::math::Pose3d pose = X_WM * X_MC;
      std::cout << (first ? "" : ",") << "{\"model\":" << Quote(name) << ",\"static\":" << (isStatic ? "true" : "false")
                << ",\"link\":" << Quote(l->Name()) << ",\"name\":" << Quote(c->Name())
                << ",\"pose\":" << (errs.empty() ? Pose(pose) : "null") << ",\"geometry\":" << Geometry(c->Geom())
                << "}";
      first = false;
    }
  }
  for (uint64_t mi = 0; mi < m->ModelCount(); ++mi) Model(m->ModelByIndex(mi), name, isStatic, X_WM, "__model__");
}


// One world file's reading, as one line of JSON.
int Dump(const std::string &file) {
  sdf::Root root;
  const sdf::Errors errors = root.Load(file);
  std::cout << "{\"file\":" << Quote(file) << ",\"errors\":[";
  for (size_t i = 0; i < errors.size(); ++i) {
    std::ostringstream e;
    e << errors[i];
    std::cout << (i ? "," : "") << Quote(e.str());
  }
  std::cout << "],\"worlds\":[";
  for (uint64_t wi = 0; wi < root.WorldCount(); ++wi) {
    const sdf::World *world = root.WorldByIndex(wi);
    std::cout << (wi ? "," : "") << "{\"name\":" << Quote(world->Name()) << ",\"collisions\":[";
    first = true;
    for (uint64_t mi = 0; mi < world->ModelCount(); ++mi) {
      Model(world->ModelByIndex(mi), "", false, ignition::math::Pose3d::Zero, "world");
    }
    std::cout << "]}";
  }
  std::cout << "]}" << std::endl;
  return errors.empty() ? 0 : 1;
}

}  // namespace

int main(int argc, char **argv) {
  if (argc < 2) {
    std::cerr << "usage: sdf_dump WORLD.sdf...\n";
    return 2;
  }
  int rc = 0;
  for (int i = 1; i < argc; ++i) rc |= Dump(argv[i]);
  return rc;
}
