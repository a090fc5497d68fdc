//VTK::PositionVC::Dec
// eyelab: the lens view's per-vertex texture coordinates into the environment image of the
// red and blue channels (the green one is VTK's own tcoord) and the lens's Fresnel
// transmittance per channel (Kakimoto 2007, §3.2: per-vertex ray tracing; one draw for all
// three channels of a dispersive lens).
in vec2 uvR;
in vec2 uvB;
in vec3 lensT;
out vec2 uvRVSOutput;
out vec2 uvBVSOutput;
out vec3 lensTVSOutput;
