//VTK::PositionVC::Impl
  uvRVSOutput = uvR;
  uvBVSOutput = uvB;
  lensTVSOutput = lensT;
