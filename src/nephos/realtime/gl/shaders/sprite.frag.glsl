// The sprite renderer's fragment shader (see sprite.vert for the programs and their defines).
uniform highp sampler2DArray sprites;
in vec2 v_uv;
flat in float v_layer;
flat in vec4 v_colour;
flat in vec3 v_diffuse;
#ifdef BENT_NORMAL
in vec3 v_bend;
in float v_bend_sun;
#endif
#ifdef SHEET
in vec2 v_rel;
flat in vec4 v_fade;
flat in vec4 v_mean;
flat in float v_dz2;
#endif
#ifdef LAYER_PAIR
in vec4 v_far;
#endif
#ifdef SHEET
uniform vec4 under;  // the sky for the first layer of a frame, written without blending; else 0
uniform float view_scale;  // 1, or 0 for the vertical view everywhere (set_layer_views)
#endif
out vec4 frag;
void main() {
#ifdef SHEET
  // Flat layers. Each texel holds the slab seen from the camera's side along the vertical
  // (r: radiance, g: opacity) and at 45 degrees (b, a), premultiplied; a pixel blends the two by
  // its view's elevation, sin^2 of its zenith angle d2 / (dz2 + d2) (0 overhead, 1/2 at 45
  // degrees), the same for both sheets of a pair (one ray). Far out on a sheet a pixel spans
  // many texels and the unfiltered texture aliases (moire at the horizon; mipmaps cost more on
  // a software rasteriser: docs/realtime.md). The footprint in texels grows as the squared
  // distance, so the texel fades to the texture's mean from 1 to 4 texels per pixel: a smooth
  // deck towards the horizon, as a filtered texture would show. And the sheet, a finite
  // square, fades out radially from 0.3 of its half-width to its edge, so that the deck
  // dissolves into the sky near the horizon instead of ending at a hard line.
  float d2 = dot(v_rel, v_rel);
#ifdef SLANT_ONLY
  // A frame whose every ray is more than 45 degrees from the vertical: the 45-degree view alone.
  vec2 ca = mix(texture(sprites, vec3(v_uv, v_layer)).ba, v_mean.ba, clamp(d2 * v_fade.x - v_fade.y, 0.0, 1.0));
#else
  float view = clamp(2.0 * d2 / (v_dz2 + d2) * view_scale, 0.0, 1.0);
  vec4 s = mix(texture(sprites, vec3(v_uv, v_layer)), v_mean, clamp(d2 * v_fade.x - v_fade.y, 0.0, 1.0));
  vec2 ca = mix(s.rg, s.ba, view);
#endif
  ca *= clamp((1.0 - d2 * v_fade.w) * EDGE_FADE, 0.0, 1.0);
  vec4 t = vec4(ca.xxx, ca.y);
#else
  vec4 t = texture(sprites, vec3(v_uv, v_layer));  // premultiplied
#endif
  vec3 c = v_colour.rgb;
#ifdef BENT_NORMAL
  // Sprites only: the wrapped diffuse term of the normalised bent normal (see the vertex shader).
  c = min(c + v_diffuse * (v_bend_sun * inversesqrt(dot(v_bend, v_bend))), vec3(1.0));
#endif
  frag = vec4(t.rgb * c, t.a) * v_colour.a;
#ifdef LAYER_PAIR
  // The farther sheet behind the nearer one (faded alike; its footprint and its position in its
  // half-widths are k times the nearer one's): the two "over" blends of separate passes,
  // composited here and blended into the frame once.
#ifdef SLANT_ONLY
  vec2 ca_far = mix(texture(sprites, vec3(v_far.xy, v_layer)).ba, v_mean.ba, clamp(d2 * v_fade.z - v_fade.y, 0.0, 1.0));
#else
  vec4 s_far = mix(texture(sprites, vec3(v_far.xy, v_layer)), v_mean, clamp(d2 * v_fade.z - v_fade.y, 0.0, 1.0));
  vec2 ca_far = mix(s_far.rg, s_far.ba, view);
#endif
  ca_far *= clamp((1.0 - dot(v_far.zw, v_far.zw)) * EDGE_FADE, 0.0, 1.0) * v_diffuse.z;
  frag += (1.0 - frag.a) * vec4(ca_far.x * c, ca_far.y);
#endif
#ifdef SHEET
  frag += (1.0 - frag.a) * under;
#endif
}
