//VTK::DepthPeeling::Impl
  // eyelab: each colour channel sampled at its own wavelength's refracted coordinates
  // (red, green = VTK's tcoord, blue) from the sRGB environment texture (decoded, and
  // filtered, in linear light by the GL), times the lens's transmittance in linear light,
  // then encoded with the exact sRGB curve (IEC 61966-2-1) for the 8-bit framebuffer.
  {
    vec3 c = vec3(texture(actortexture, uvRVSOutput).r,
                  texture(actortexture, tcoordVCVSOutput).g,
                  texture(actortexture, uvBVSOutput).b) * lensTVSOutput;
    c = clamp(c, 0.0, 1.0);
    fragOutput0 = vec4(mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055,
                           step(vec3(0.0031308), c)), 1.0);
  }
