"""Post-processing: machines, kinematics, dialect plug-ins, APT CLDATA and NC I/O."""
