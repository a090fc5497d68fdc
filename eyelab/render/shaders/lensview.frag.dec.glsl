//VTK::TCoord::Dec
in vec2 uvRVSOutput;
in vec2 uvBVSOutput;
in vec3 lensTVSOutput;
