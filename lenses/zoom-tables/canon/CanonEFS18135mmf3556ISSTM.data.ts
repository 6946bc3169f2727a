// The patent's numbers of US 2013/0088622 Example 4 as LensVisualizer transcribes them
// (src/lens-data/canon/CanonEFS18135mmf3556ISSTM.data.ts, commit 95431a2e9a56): radii, gaps, the
// zoom states' focal lengths, variable gaps at infinity focus and F-numbers. Rows only (no glass).
// The patent's surface 1, a plane dummy 1.5 mm in front of surface 2 that LensVisualizer omits, is
// listed as the Optical Bench transcription (the library file) has it.
const LENS_DATA = {
  surfaces: [
    { label: "1", R: 1e15, d: 1.5, nd: 1.0, elemId: 0 },
    { label: "2", R: 107.732, d: 1.9, nd: 1.84666, elemId: 1 },
    { label: "3", R: 60.391, d: 7.57, nd: 1.497, elemId: 2 },
    { label: "4", R: -1239.687, d: 0.15, nd: 1.0, elemId: 0 },
    { label: "5", R: 53.128, d: 6.09, nd: 1.60311, elemId: 3 },
    { label: "6", R: 238.329, d: 0.9, nd: 1.0, elemId: 0 },
    { label: "7", R: 164.319, d: 1.45, nd: 1.83481, elemId: 4 },
    { label: "8", R: 15.295, d: 6.85, nd: 1.0, elemId: 0 },
    { label: "9", R: -53.79, d: 1.2, nd: 1.7725, elemId: 5 },
    { label: "10", R: 50.684, d: 0.88, nd: 1.0, elemId: 0 },
    { label: "11", R: 29.817, d: 5.57, nd: 1.84666, elemId: 6 },
    { label: "12", R: -59.549, d: 1.1, nd: 1.7725, elemId: 7 },
    { label: "13", R: 91.992, d: 25.44, nd: 1.0, elemId: 0 },
    { label: "14", R: 57.606, d: 1.95, nd: 1.80518, elemId: 8 },
    { label: "15", R: -73.234, d: 2.65, nd: 1.0, elemId: 0 },
    { label: "16", R: -35.671, d: 0.7, nd: 1.90366, elemId: 9 },
    { label: "17", R: 150.44, d: 6.67, nd: 1.0, elemId: 0 },
    { label: "18", R: 30.381, d: 3.4, nd: 1.60311, elemId: 10 },
    { label: "19", R: -41.483, d: 0.83, nd: 1.0, elemId: 0 },
    { label: "STO", R: 1e15, d: 3.3, nd: 1.0, elemId: 0 },
    { label: "21", R: 25.373, d: 4.95, nd: 1.60311, elemId: 11 },
    { label: "22", R: -21.035, d: 0.75, nd: 1.84666, elemId: 12 },
    { label: "23", R: 86.598, d: 3.56, nd: 1.0, elemId: 0 },
    { label: "24", R: -136.978, d: 0.7, nd: 1.7495, elemId: 13 },
    { label: "25", R: 12.387, d: 2.58, nd: 1.84666, elemId: 14 },
    { label: "26", R: 30.397, d: 5.22, nd: 1.0, elemId: 0 },
    { label: "27A", R: 47.113, d: 1.0, nd: 1.72151, elemId: 15 },
    { label: "28", R: 31.941, d: 3.58, nd: 1.59551, elemId: 16 },
    { label: "29", R: -38.622, d: 35.6, nd: 1.0, elemId: 0 },
  ],
  var: {
    "6": [[0.9], [22.59], [42.1]],
    "13": [[25.44], [7.28], [1.5]],
    "15": [[2.65], [4.09], [7.85]],
    "17": [[6.67], [5.23], [1.47]],
    "26": [[5.22], [2.39], [1.3]],
    "29": [[35.6], [55.89], [71.7]],
  },
  zoomPositions: [18.6, 50.99, 130.48],
  nominalFno: [3.59, 4.88, 5.97],
};
