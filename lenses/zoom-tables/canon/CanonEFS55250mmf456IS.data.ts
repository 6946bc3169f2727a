// The patent's numbers of US 7,471,462 Example 2 as LensVisualizer transcribes them
// (src/lens-data/canon/CanonEFS55250mmf456IS.data.ts, commit 56c99ef6bf15): radii, gaps, the zoom
// states' focal lengths, variable gaps at infinity focus and F-numbers. Rows only (no glass).
const LENS_DATA = {
  surfaces: [
    { label: "1", R: 80.99515, d: 4.75045, nd: 1.51633, elemId: 1 },
    { label: "2", R: -808.56, d: 0.15, nd: 1.0, elemId: 0 },
    { label: "3", R: 77.54341, d: 2.6, nd: 1.801, elemId: 2 },
    { label: "4", R: 41.96489, d: 5.6768, nd: 1.497, elemId: 3 },
    { label: "5", R: 338.8565, d: 7.19326, nd: 1.0, elemId: 0 },
    { label: "6", R: -209.128, d: 1.4, nd: 1.713, elemId: 4 },
    { label: "7", R: 19.23569, d: 3.20257, nd: 1.84666, elemId: 5 },
    { label: "8", R: 44.55107, d: 2.32179, nd: 1.0, elemId: 0 },
    { label: "9", R: -43.5451, d: 1.1, nd: 1.804, elemId: 6 },
    { label: "10", R: 278.5068, d: 31.47406, nd: 1.0, elemId: 0 },
    { label: "11", R: 52.26289, d: 2.99623, nd: 1.63854, elemId: 7 },
    { label: "12", R: -95.0852, d: 0.15, nd: 1.0, elemId: 0 },
    { label: "13", R: 47.03856, d: 2.89978, nd: 1.60311, elemId: 8 },
    { label: "14", R: -231.037, d: 1.56909, nd: 1.0, elemId: 0 },
    { label: "STO", R: 1e15, d: 0.49801, nd: 1.0, elemId: 0 },
    { label: "16", R: 30.2435, d: 2.78922, nd: 1.48749, elemId: 9 },
    { label: "17", R: 226.3014, d: 0.60067, nd: 1.0, elemId: 0 },
    { label: "18", R: -125.291, d: 3.02154, nd: 1.84666, elemId: 10 },
    { label: "19", R: 49.05197, d: 11.42731, nd: 1.0, elemId: 0 },
    { label: "20", R: 65.37414, d: 2.01377, nd: 1.834, elemId: 11 },
    { label: "21", R: 23.64292, d: 8.70092, nd: 1.0, elemId: 0 },
    { label: "22", R: 47.7313, d: 2.36466, nd: 1.68893, elemId: 12 },
    { label: "23", R: -173.907, d: 52.45312963327591, nd: 1.0, elemId: 0 },
  ],
  var: {
    "5": [[7.19326], [42.37555], [47.94835]],
    "10": [[31.47406], [11.1426], [1.265538]],
    "23": [[52.45312963327591], [67.88393664908017], [82.57241153237486]],
  },
  zoomPositions: [56.9, 160.8, 241.3],
  nominalFno: [4.16, 5.129132321041215, 5.88],
};
