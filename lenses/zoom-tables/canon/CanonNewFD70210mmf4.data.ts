// The patent's numbers of US 4,380,377 Example 1 (Canon, "Compact zoom lens"; the Canon New FD
// 70-210mm f/4): radii, thicknesses, nd, the zoom states' focal lengths (70.55 / 137.04 / 205.31 mm),
// the variable gaps d5, d10, d13 at infinity focus, F/4 at every state. Not a LensVisualizer table
// (it has none of this patent): read from a transcription of the patent's Example 1 in a public
// repository's notes on lens prescriptions (found through a code index that does not name the
// repository; the notes say the table was read from the patent's full text at patents.justia.com and
// checked against the USPTO PDF's page image). Checked here: the rows are the library file's own (the
// Optical Bench's transcription of the same example, to its six significant figures), its gaps are
// the wide state's, and the three gaps sum to 53.24 mm at every state (groups I, IV and V fixed).
// The patent prints no stop and no back focus: the last row's d is unused (the focus solve places the
// sensor), and the STO row is the library file's (the Optical Bench's) place for the stop, 1 mm in
// front of group IV (fixed), so that the patent's d13 appears as d13 - 1 here.
const LENS_DATA = {
  source: "US 4,380,377 Example 1's table, read from a transcription of the patent in a public repository's notes (the repository is not named by the code index it was found through), checked against the library file's rows and the gaps' constant sum",
  elements: [
    { id: 1, nd: 1.80518, vd: 25.4 },
    { id: 2, nd: 1.61272, vd: 58.7 },
    { id: 3, nd: 1.61272, vd: 58.7 },
    { id: 4, nd: 1.713, vd: 53.9 },
    { id: 5, nd: 1.713, vd: 53.9 },
    { id: 6, nd: 1.84666, vd: 23.0 },
    { id: 7, nd: 1.51633, vd: 64.1 },
    { id: 8, nd: 1.7552, vd: 27.5 },
    { id: 9, nd: 1.61272, vd: 58.7 },
    { id: 10, nd: 1.80518, vd: 25.4 },
    { id: 11, nd: 1.8061, vd: 40.9 },
    { id: 12, nd: 1.59551, vd: 39.2 },
  ],
  surfaces: [
    { label: "1", R: 144.296, d: 2.8, nd: 1.80518, elemId: 1 },
    { label: "2", R: 67.895, d: 6.6, nd: 1.61272, elemId: 2 },
    { label: "3", R: -4571.825, d: 0.2, nd: 1, elemId: 0 },
    { label: "4", R: 94.482, d: 4.7, nd: 1.61272, elemId: 3 },
    { label: "5", R: 26667.449, d: 0.5, nd: 1, elemId: 0 },
    { label: "6", R: 464.312, d: 1.5, nd: 1.713, elemId: 4 },
    { label: "7", R: 40.285, d: 4.2, nd: 1, elemId: 0 },
    { label: "8", R: -45.202, d: 1.5, nd: 1.713, elemId: 5 },
    { label: "9", R: 44.784, d: 3.4, nd: 1.84666, elemId: 6 },
    { label: "10", R: -3270.421, d: 34.12, nd: 1, elemId: 0 },
    { label: "11", R: 108.4, d: 5.8, nd: 1.51633, elemId: 7 },
    { label: "12", R: -32.441, d: 1.5, nd: 1.7552, elemId: 8 },
    { label: "13", R: -56.83, d: 17.62, nd: 1, elemId: 0 },
    { label: "STO", R: 1e15, d: 1, nd: 1, elemId: 0 },
    { label: "14", R: 36.187, d: 4.5, nd: 1.61272, elemId: 9 },
    { label: "15", R: 797.679, d: 1.95, nd: 1, elemId: 0 },
    { label: "16", R: -213.357, d: 2, nd: 1.80518, elemId: 10 },
    { label: "17", R: 570.712, d: 47.33, nd: 1, elemId: 0 },
    { label: "18", R: -19.993, d: 2, nd: 1.8061, elemId: 11 },
    { label: "19", R: -42.359, d: 0.3, nd: 1, elemId: 0 },
    { label: "20", R: 172.917, d: 3.5, nd: 1.59551, elemId: 12 },
    { label: "21", R: -61.717, d: 0, nd: 1, elemId: 0 },
  ],
  var: {
    "5": [[0.5], [32.54], [43.86]],
    "10": [[34.12], [17.63], [0.68]],
    "13": [[17.62], [2.07], [7.7]],
  },
  zoomPositions: [70.55, 137.04, 205.31],
};
