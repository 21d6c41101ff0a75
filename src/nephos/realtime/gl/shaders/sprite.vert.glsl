// The sprite renderer's vertex shader, one body for GLSL ES 3.00 and GLSL 3.30 core (the
// renderer prepends the version line and the defines of each program: BENT_NORMAL, SHEET,
// LAYER_PAIR, SLANT_ONLY). Instance data (17 floats): position relative to the camera [m] and
// size [m]; colour (ambient + per-shading-group directional, premultiplied by the cloud's
// opacity) and alpha; texture layer and sheet tiling; bent-normal diffuse colour; fixed facing
// direction and height/width ratio. A flat-layer pair (LAYER_PAIR) reuses the last two:
// diffuse.z is the farther layer's opacity, facing_aspect.x the ratio of its height above (or
// below) the camera to the nearer one's.
layout(location = 0) in vec3 vertex;        // an octagon vertex: signs of x and y; 1 if it ends an
                                            // edge |x| = a (else |y| = b): see SpriteTrim
layout(location = 1) in vec4 pos_size;      // position relative to the camera [m], size [m]
layout(location = 2) in vec4 colour_alpha;  // shaded colour, alpha (opacity: formation, crossfade)
layout(location = 3) in vec2 layer_tiles;   // texture layer; y > 0: horizontal sheet tiled y times;
                                            // y < 0: impostor quad (render-to-texture, v flipped)
layout(location = 4) in vec3 diffuse;       // colour of the bent-normal diffuse term (thesis B.7);
                                            // sheets: xy = texture offset [tiles] (ground-fixed)
layout(location = 5) in vec4 facing_aspect; // fixed facing (away from the viewer) and height/width;
                                            // zero: a camera-facing billboard
uniform mat4 view_proj;
uniform vec3 trim[TRIM_LAYERS];  // per texture layer: |x| <= a, |y| <= b, |x| + |y| <= c
uniform vec3 cam_right;
uniform vec3 cam_up;
// Per-instance values are flat: the same at every vertex, which a rasteriser need not
// interpolate per fragment.
out vec2 v_uv;
flat out float v_layer;
flat out vec4 v_colour;
flat out vec3 v_diffuse;
#ifdef BENT_NORMAL
uniform vec3 sun_dir;  // towards the sun
uniform vec3 cam_front;
out vec3 v_bend;      // the unnormalised bent normal
out float v_bend_sun; // its dot product with the sun direction
#endif
#ifdef SHEET
uniform vec4 sheet_mean[SHEET_LAYERS];  // each flat-layer texture's mean texel
out vec2 v_rel;        // position relative to the camera on the (nearer) sheet [tiles]
flat out vec4 v_fade;  // distance fade: nearer sheet's scale [1/tiles^2], offset, farther sheet's
                       // scale; 1 / the sheet's half-width^2 [1/tiles^2]
flat out vec4 v_mean;  // the layer texture's mean texel
flat out float v_dz2;  // the (nearer) sheet's height above or below the camera, squared [tiles^2]
#endif
#ifdef LAYER_PAIR
out vec4 v_far;  // the farther layer: texture coordinates [tiles], position [its half-widths]
#endif
void main() {
  // Sprites cover the octagon of their texture layer's non-transparent texels (the fill is the
  // cost on a software rasteriser); other draws set every layer's octagon to the whole quad.
  vec3 t = trim[int(layer_tiles.x)];
  vec2 corner = vertex.xy * (vertex.z > 0.5 ? vec2(t.x, min(t.y, t.z - t.x)) : vec2(min(t.x, t.z - t.y), t.y));
  vec3 ax = cam_right;
  vec3 ay = cam_up;
  float aspect = 1.0;
  if (layer_tiles.y > 0.0) {
    ax = vec3(1.0, 0.0, 0.0);
    ay = vec3(0.0, 1.0, 0.0);
  } else if (dot(facing_aspect.xyz, facing_aspect.xyz) > 0.0) {
    vec3 f = normalize(facing_aspect.xyz);
    ax = normalize(cross(f, vec3(0.0, 0.0, 1.0)));
    ay = cross(ax, f);
    aspect = facing_aspect.w;
  }
  vec3 p = pos_size.xyz + 0.5 * pos_size.w * (corner.x * ax + corner.y * aspect * ay);
  gl_Position = view_proj * vec4(p, 1.0);
  vec2 uv = corner * vec2(0.5, -0.5) + 0.5;
  if (layer_tiles.y < 0.0) uv.y = 1.0 - uv.y;
  v_uv = layer_tiles.y > 0.0 ? uv * layer_tiles.y + diffuse.xy : uv;
  v_layer = layer_tiles.x;
  v_colour = colour_alpha;
  v_diffuse = diffuse;
#ifdef BENT_NORMAL
  // Thesis B.7: the billboard normal, turned to the sun's side of the view, bent outwards by
  // the fragment's offset from the centre (in half-sizes). Both it and its dot product with the
  // sun are affine in the corner, so they interpolate exactly and the fragment only normalises.
  v_bend = (dot(cam_front, sun_dir) < 0.0 ? -cam_front : cam_front) + 0.5 * (corner.x * ax + corner.y * ay);
  v_bend_sun = dot(v_bend, sun_dir);
  // The wrapped diffuse term d (n.l + 1) / 2 as (d / 2) + (d / 2) n.l: the constant half joins
  // the colour here instead of in every fragment.
  v_diffuse = 0.5 * diffuse;
  v_colour.rgb += v_diffuse;
#endif
#ifdef SHEET
  // Flat layers: facing_aspect.yz hold the distance fade's scale and offset (see the fragment
  // shader), facing_aspect.x the farther sheet's height ratio (a pair; its pixel footprint in
  // texels is that many times the nearer sheet's at the same pixel).
  v_rel = (uv - 0.5) * layer_tiles.y;
  v_fade = vec4(facing_aspect.y, facing_aspect.z, facing_aspect.y * facing_aspect.x, 4.0 / (layer_tiles.y * layer_tiles.y));
  v_mean = sheet_mean[int(layer_tiles.x) - FIRST_SHEET_LAYER];
  float dz = pos_size.z * layer_tiles.y / pos_size.w;  // metres to tiles
  v_dz2 = dz * dz;
#endif
#ifdef LAYER_PAIR
  // The view ray through this point of the nearer sheet meets the farther one, k times as far
  // above (below) the camera, at k times the horizontal offset: an affine map of the corner, so
  // interpolated exactly. Both sheets are centred on the camera with the same tiling and offset.
  vec2 far_corner = corner * facing_aspect.x;
  v_far = vec4((far_corner * vec2(0.5, -0.5) + 0.5) * layer_tiles.y + diffuse.xy, far_corner);
#endif
}
