GOCAD TSurf 1 
HEADER {
name: test
mesh: on
cn: on
*solid*color: 1 0.447059 0.337255 1
}
GOCAD_ORIGINAL_COORDINATE_SYSTEM
NAME " Pdgm_Epic Local" 
PROJECTION Unknown
DATUM Unknown
AXIS_NAME X Y Z
AXIS_UNIT m m m
ZPOSITIVE Depth
END_ORIGINAL_COORDINATE_SYSTEM
PROPERTIES " default property"  def-prop
PROP_LEGAL_RANGES **none**  **none** **none**  **none** 
NO_DATA_VALUES -99999 -99999 
PROPERTY_CLASSES " default property"  def-prop
PROPERTY_KINDS " Real Number"  " Real Number" 
PROPERTY_SUBCLASSES QUANTITY Float QUANTITY Float
ESIZES 1  1 
UNITS unitless unitless
PROPERTY_CLASS_HEADER X {
kind: X
unit: m
}
PROPERTY_CLASS_HEADER Y {
kind: Y
unit: m
}
PROPERTY_CLASS_HEADER Z {
kind: Z
unit: m
is_z: on
}
PROPERTY_CLASS_HEADER vector3d {
kind: Length
unit: m
}
PROPERTY_CLASS_HEADER default property {
name: default property
}
PROPERTY_CLASS_HEADER def-prop {
kind: Real Number
unit: unitless
name: def-prop
}
TFACE
PVRTX 1 -745925.546875 -2618524.8125 -44070.2578125 -99999 -99999 CNXYZ
PVRTX 2 -883301.09375 -2717022.15625 -15210.8740234375 -99999 -99999 CNXYZ
PVRTX 3 -870695.75 -2463857.25 -110115.6171875 -99999 -99999 CNXYZ
PVRTX 4 -1008071.3125 -2562354.625 -81256.234375 -99999 -99999 CNXYZ
TRGL 3 2 1 
TRGL 4 2 3 
BSTONE 1 
BORDER 5 1 2 
END
