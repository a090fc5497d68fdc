//VTK::PositionVC::Dec
// eyelab: the blur field as a 3D RGBA32F texture (m00, m01, m10, m11) over the camera's
// view volume (Kakimoto 2007, §4.5). The custom uniforms seed, depthMode (0: slices
// uniform in NDC z; 1: uniform in eye-space depth w), nearPlane and farPlane are declared
// by VTK itself; the sampler, bound by an observer, is declared here.
uniform sampler3D blurField;
