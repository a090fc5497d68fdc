//VTK::PositionVC::Impl
  {
    // eyelab: look the vertex's blur-field matrix up in the 3D texture and displace it in
    // NDC by B * seed (Kakimoto 2007, §4.5). mat2 is column-major.
    // `tile` (sx, sy, cx, cy) maps a sub-rectangle's NDC to the whole view's (1, 1, 0, 0
    // for the whole view): the field is looked up, and displaces, in the whole view's NDC
    vec3 ndcP = gl_Position.xyz / gl_Position.w;
    ndcP.xy = ndcP.xy * tile.xy + tile.zw;
    float tz = depthMode < 0.5 ? ndcP.z * 0.5 + 0.5
                               : (gl_Position.w - nearPlane) / (farPlane - nearPlane);
    vec4 m = texture(blurField, vec3(ndcP.xy * 0.5 + 0.5, tz));
    if (gl_Position.w > 0.0) {
      // plus the pass's sub-pixel `jitter` (NDC): the S passes also antialias
      gl_Position.xy += ((mat2(m.x, m.z, m.y, m.w) * seed) / tile.xy + jitter) * gl_Position.w;
    }
  }
