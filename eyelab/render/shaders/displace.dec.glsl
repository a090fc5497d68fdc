//VTK::PositionVC::Dec
// eyelab: per-vertex blur-field matrix (Kakimoto 2007, Eq. 9), row-major (m00, m01, m10, m11),
// looked up on the CPU at the vertex (trilinear, as a 3D texture would be sampled).
in vec4 blurM;
