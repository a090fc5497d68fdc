//VTK::DepthPeeling::Impl
  // eyelab: the fragment's colour is linear light (sRGB textures are decoded, and filtered
  // and mip-mapped, in linear light by the GL); encode it for the 8-bit framebuffer with
  // the exact sRGB curve (IEC 61966-2-1), so that read-backs hold sRGB codes.
  {
    vec3 c = clamp(fragOutput0.rgb, 0.0, 1.0);
    fragOutput0.rgb = mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055,
                          step(vec3(0.0031308), c));
  }
