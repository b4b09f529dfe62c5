#pragma once
// The check of the bytes a scene names as an OBJ mesh, before tinyobjloader parses them.
//
// tinyobjloader skips every line it does not understand, so without this check a glTF file, an
// empty file, random bytes or a text with a typo would load as a mesh with no (or fewer)
// triangles, and the object would silently be missing from the image.
//
// Accepted: Wavefront OBJ text with at least one face: comments, every statement of the OBJ
// specification (v vt vn vp f l p g o s mg usemtl mtllib, the free-form ones, ...), LF, CRLF or
// CR line endings, spaces or tabs, trailing whitespace, a UTF-8 byte-order mark, lines continued
// with a backslash, faces of 3 or more vertices written v, v/vt, v//vn or v/vt/vn with positive
// (1-based) or negative (relative) indices, `fo` (the old spelling of `f`).
//
// Refused, with one reason (docs/scene-format.md lists them): an empty file; a file of another
// format (glTF, binary glTF, JSON, XML/HTML, PLY, STL, FBX, PNG, JPEG, ZIP, gzip); binary data;
// a line that is not an OBJ statement; a vertex that is not 3 to 7 finite numbers or whose
// coordinates exceed 1e30 in magnitude; a normal that is not 3 finite numbers; a texture
// coordinate or parameter vertex that is not 1 to 3 finite numbers; a face of
// fewer than 3 vertices, with an index of 0, not an integer, or referring to a vertex not
// defined before it; a file with no face.
#include <cstddef>
#include <string>
#include <string_view>

namespace lensfarm {

struct ObjCheck {
  // Empty when the bytes are an OBJ with at least one face; otherwise why not, e.g.
  // "empty file" or "line 3: 'xyz' is not an OBJ statement".
  std::string problem;
  // What tinyobjloader should parse: the text without a byte-order mark, continued lines joined
  // (each joined line leaves an empty line, so line numbers stay those of the file) and `fo` as
  // `f`. Empty when there is a problem.
  std::string text;
  size_t vertices = 0;  // `v` statements
  size_t faces = 0;     // `f` statements

  bool ok() const { return problem.empty(); }
};

ObjCheck checkObjText(std::string_view bytes);

// The same, the text written over the bytes themselves (moved in): a big file is not held twice.
ObjCheck checkObjTextInPlace(std::string bytes);

}  // namespace lensfarm
