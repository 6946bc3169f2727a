// The patent's numbers of US 5,249,079 A Table 4 as LensVisualizer transcribes them
// (src/lens-data/minolta/Minolta35135mmf3545MDZoom.data.ts, commit c8bc9fdbd1e9): radii, gaps, the
// zoom states' focal lengths and variable gaps at infinity focus. Rows only (no glass). Its
// nominalFno is a fixed-stop model's; the patent's F-numbers (3.608 / 4.56) are those its header
// quotes (merge_zoom_states.py, F_NUMBER_OVERRIDES).
const LENS_DATA = {
  surfaces: [
    { label: "1", R: 155.12197, d: 2.2, nd: 1.80518, elemId: 1 },
    { label: "2", R: 51.21901, d: 7.1, nd: 1.5168, elemId: 2 },
    { label: "3", R: -287.11129, d: 0.15, nd: 1, elemId: 0 },
    { label: "4", R: 50.297, d: 4.5, nd: 1.7725, elemId: 3 },
    { label: "5", R: 309.92376, d: 0.823, nd: 1, elemId: 0 },
    { label: "6", R: 100.68405, d: 1.3, nd: 1.7545, elemId: 4 },
    { label: "7", R: 15.885, d: 4.15, nd: 1, elemId: 0 },
    { label: "8", R: -96.119, d: 1.2, nd: 1.6968, elemId: 5 },
    { label: "9", R: 44.324, d: 0.15, nd: 1, elemId: 0 },
    { label: "10", R: 24.656, d: 2.7, nd: 1.84666, elemId: 6 },
    { label: "11", R: 347.43575, d: 1.6, nd: 1, elemId: 0 },
    { label: "12", R: -30.049, d: 1.1, nd: 1.618, elemId: 7 },
    { label: "13", R: 289.4356, d: 18.996, nd: 1, elemId: 0 },
    { label: "STO", R: 1e15, d: 1.24, nd: 1, elemId: 0 },
    { label: "15", R: 88.90098, d: 2.4, nd: 1.5168, elemId: 8 },
    { label: "16", R: -52.114, d: 0.15, nd: 1, elemId: 0 },
    { label: "17", R: 35.739, d: 4.2, nd: 1.54072, elemId: 9 },
    { label: "18", R: -35.739, d: 1.2, nd: 1.7552, elemId: 10 },
    { label: "19", R: 214.30806, d: 9.041, nd: 1, elemId: 0 },
    { label: "20", R: 33.161, d: 3.18, nd: 1.60342, elemId: 11 },
    { label: "21", R: 240.2691, d: 7.47, nd: 1, elemId: 0 },
    { label: "22", R: -85.75998, d: 4.55, nd: 1.80741, elemId: 12 },
    { label: "23", R: 30.608, d: 1.94, nd: 1, elemId: 0 },
    { label: "24", R: -196.06305, d: 3, nd: 1.5168, elemId: 13 },
    { label: "25", R: -29.783, d: 0.2, nd: 1, elemId: 0 },
    { label: "26", R: 38.452, d: 4.2, nd: 1.51742, elemId: 14 },
    { label: "27", R: -166.695, d: 53.268774, nd: 1, elemId: 0 },
  ],
  var: {
    "5": [[0.823], [27.032]],
    "13": [[18.996], [1.1]],
    "19": [[9.041], [0.728]],
    "27": [[53.268774], [78.369634]],
  },
  zoomPositions: [35.9, 131.5],
  nominalFno: [3.610666, 4.55663],
};
