//VTK::PositionVC::Impl
  // eyelab: displace the vertex in NDC by B * seed (Kakimoto 2007, §4.5); `seed` is a point
  // of the unit disc set per pass. mat2 is column-major: columns (m00, m10), (m01, m11).
  // `jitter` is the pass's sub-pixel offset (NDC): the S passes also antialias.
  // `tile` (sx, sy, cx, cy): a sub-rectangle's NDC scale and centre in the whole view's
  gl_Position.xy += ((mat2(blurM.x, blurM.z, blurM.y, blurM.w) * seed) / tile.xy + jitter)
                    * gl_Position.w;
